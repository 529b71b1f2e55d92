//! The `lente` command line.

fn main() {
    println!("lente");
}
