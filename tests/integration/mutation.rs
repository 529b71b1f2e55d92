//! Random text mutations of a valid scene, for the readers' no-panic tests:
//! every mutant must either load or fail with a located error.

use lente::load::SceneError;

/// A small deterministic generator (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// 1 to 4 random edits of `base`: delete a character or a run, duplicate a
/// run in place, or insert a character from `pool`.
fn mutate(base: &[char], pool: &[char], rng: &mut Rng) -> String {
    let mut s = base.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(s.len() + 1).min(s.len());
        match rng.below(5) {
            0 if !s.is_empty() => {
                s.remove(at.min(s.len() - 1));
            }
            1 => {
                let end = (at + 1 + rng.below(20)).min(s.len());
                s.drain(at..end);
            }
            2 => {
                let end = (at + 1 + rng.below(40)).min(s.len());
                let run: Vec<char> = s[at..end].to_vec();
                s.splice(at..at, run);
            }
            _ => {
                let c = pool[rng.below(pool.len())];
                s.insert(at, c);
            }
        }
    }
    s.into_iter().collect()
}

/// Loads 2000 mutants of `base` (`LENTE_MUTATIONS=100000` runs a longer
/// search by hand), with characters to insert drawn from `pool`. Fails if
/// `load` panics, if an error carries no position (unless it truly has
/// none), or if either outcome is rare: then the mutations test nothing.
pub fn loads_or_fails_located<T>(
    base: &str,
    pool: &str,
    seed: u64,
    load: impl Fn(&str) -> Result<T, SceneError>,
) {
    let base: Vec<char> = base.chars().collect();
    let pool: Vec<char> = pool.chars().collect();
    let mut rng = Rng(seed);
    let (mut ok, mut failed) = (0, 0);
    let count: usize = std::env::var("LENTE_MUTATIONS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2000);
    for i in 0..count {
        let text = mutate(&base, &pool, &mut rng);
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| load(&text)));
        match result {
            Ok(Ok(_)) => ok += 1,
            Ok(Err(e)) => {
                failed += 1;
                assert!(e.line > 0 || e.message.contains("no element"), "{e}");
            }
            Err(_) => panic!("mutation {i} made the loader panic:\n{text}"),
        }
    }
    eprintln!("{count} mutants: {ok} loaded, {failed} rejected");
    assert!(ok > 50 && failed > 50, "ok {ok}, failed {failed}");
}
