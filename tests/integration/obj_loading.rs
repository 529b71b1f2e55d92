//! OBJ loading: polygons are triangulated, negative (relative) indices
//! resolve, missing normals fall back to geometric ones, and shading normals
//! are interpolated.

use lente::geometry::load_obj;
use lente::math::Vec3;

/// Writes `text` to a file `name` in a fresh folder (kept while the TempDir lives).
fn write(name: &str, text: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    (dir, p)
}

#[test]
fn polygons_and_negative_indices() {
    // A pentagon with relative indices, and a quad with absolute ones.
    let (_dir, p) = write(
        "poly.obj",
        "v 0 0 0\nv 1 0 0\nv 1.5 1 0\nv 0.5 1.8 0\nv -0.5 1 0\nf -5 -4 -3 -2 -1\n\
         v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 6 7 8 9\n",
    );
    let m = load_obj(&p).unwrap();
    assert_eq!(m.triangle_count(), 3 + 2);
    // The pentagon's fan covers its whole area.
    let pent: f32 = (0..3).map(|t| m.triangle_area(t)).sum();
    let expect = 0.5
        * [
            (0.0f32, 0.0f32),
            (1.0, 0.0),
            (1.5, 1.0),
            (0.5, 1.8),
            (-0.5, 1.0),
        ]
        .windows(2)
        .chain(std::iter::once(&[(-0.5, 1.0), (0.0, 0.0)][..]))
        .map(|w| w[0].0 * w[1].1 - w[1].0 * w[0].1)
        .sum::<f32>();
    assert!((pent - expect).abs() < 1e-5, "{pent} vs {expect}");
    // No normals in the file: geometric normals (+z for CCW in the xy plane).
    assert!(m.normals().is_empty());
    let (n, _) = m.shading(0, 0.2, 0.2);
    assert!((n - Vec3::Z).length() < 1e-6);
}

#[test]
fn shading_normals_are_interpolated() {
    let (_dir, p) = write(
        "normals.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn -1 0 1\nvn 1 0 1\nvn 0 1 1\nvt 0 0\nvt 1 0\nvt 0 1\n\
         f 1/1/1 2/2/2 3/3/3\n",
    );
    let m = load_obj(&p).unwrap();
    let (n, uv) = m.shading(0, 0.5, 0.0);
    // Halfway between vertex 0 and vertex 1: normalize((0, 0, 1)).
    assert!((n - Vec3::Z).length() < 1e-5, "{n:?}");
    assert!((uv.x - 0.5).abs() < 1e-6 && uv.y.abs() < 1e-6);
}

#[test]
fn broken_files_are_errors() {
    let missing = std::env::temp_dir().join("lente-no-such-file.obj");
    assert!(load_obj(&missing)
        .unwrap_err()
        .to_string()
        .contains("lente-no-such-file.obj"));
    let (_dir, p) = write("bad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 9\n");
    assert!(load_obj(&p).is_err());
    let (_dir, p) = write("empty.obj", "# nothing\n");
    assert!(load_obj(&p).is_err());
}
