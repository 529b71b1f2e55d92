//! Instancing: a shape group placed by instances is hit exactly where
//! copies of its shapes, transformed the same way, are hit; spawned rays
//! leave instanced surfaces; the reader enforces Mitsuba's rules.

use lente::geometry::BvhHit;
use lente::math::{Ray, Vec3};
use lente::sampling::{warp, Sampler};
use lente::scene::Scene;

use crate::common::load_clean;
use crate::mitsuba_parse::{assert_err, scene};

const GROUP: &str = r#"
    <shape type="cube"><transform name="to_world"><scale value="0.5"/><translate x="1"/></transform></shape>
    <shape type="sphere"><point name="center" value="-1, 0.2, 0"/><float name="radius" value="0.6"/></shape>
    <shape type="rectangle"><transform name="to_world"><scale x="0.8" y="0.4"/><rotate x="1" angle="30"/><translate z="-1"/></transform></shape>
"#;

/// Placements that keep a sphere a sphere (so copies can be written out),
/// one of them a mirror.
const PLACEMENTS: [&str; 3] = [
    "",
    r#"<rotate y="1" angle="50"/><scale value="1.5"/><translate x="3" y="1"/>"#,
    r#"<scale x="-1" y="1" z="1"/><rotate x="1" angle="-20"/><translate x="-3" z="2"/>"#,
];

fn built(body: &str) -> Scene {
    Scene::new(load_clean(&scene(body)).scene).unwrap()
}

/// The group's shapes with the placement written before their own transforms.
fn copies(placement: &str) -> String {
    GROUP
        .replace("</transform></shape>", &format!("{placement}</transform></shape>"))
        .replace(
            r#"<float name="radius" value="0.6"/></shape>"#,
            &format!(
                r#"<float name="radius" value="0.6"/><transform name="to_world">{placement}</transform></shape>"#
            ),
        )
}

fn random_ray(s: &mut Sampler) -> Ray {
    let o = (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * 14.0;
    let target = (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * 6.0;
    Ray::new(o, (target - o).normalize())
}

#[test]
fn instances_are_hit_where_transformed_copies_are() {
    let instanced = built(&format!(
        r#"<shape type="shapegroup" id="g">{GROUP}</shape>{}"#,
        PLACEMENTS
            .iter()
            .map(|p| format!(
                r#"<shape type="instance"><ref id="g"/><transform name="to_world">{p}</transform></shape>"#
            ))
            .collect::<String>()
    ));
    let copied = built(&PLACEMENTS.iter().map(|p| copies(p)).collect::<String>());
    assert_eq!(instanced.bvh.instance_count(), 3);
    // One copy of the group's geometry, however many instances.
    assert_eq!(instanced.geometry.len(), 3);
    assert_eq!(copied.geometry.len(), 9);

    let mut s = Sampler::new(5, 0);
    let (mut hits, mut disagree) = (0, 0);
    let n = 40_000;
    for _ in 0..n {
        let ray = random_ray(&mut s);
        match (instanced.intersect(&ray), copied.intersect(&ray)) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                hits += 1;
                assert_ne!(a.instance, BvhHit::NO_INSTANCE);
                // Shapes are numbered per group, copies per placement.
                assert_eq!(a.shape as usize, b.shape as usize % 3);
                assert_eq!(a.instance, b.shape / 3);
                let tol = 1e-4 * a.t.max(1.0);
                assert!((a.t - b.t).abs() < tol, "t {} vs {}", a.t, b.t);
                assert!(a.p.distance(b.p) < 10.0 * tol, "p {} vs {}", a.p, b.p);
                assert!(a.ng.dot(b.ng) > 0.9999, "ng {} vs {}", a.ng, b.ng);
                assert!(a.shading.n.dot(b.shading.n) > 0.9999);
                assert!(
                    a.shading.s.dot(b.shading.s) > 0.999,
                    "shape {} instance {}: s {} vs {}",
                    a.shape,
                    a.instance,
                    a.shading.s,
                    b.shading.s
                );
                assert!(
                    (a.uv - b.uv).abs().max_element() < 1e-3,
                    "uv {} vs {}",
                    a.uv,
                    b.uv
                );
                // A bound, and a tight one.
                let scale = a.p.abs().max_element().max(1.0);
                assert!(a.err.min_element() > 0.0 && a.err.max_element() < 1e-5 * scale);
            }
            // A ray grazing an edge may round to the other side in one space.
            _ => disagree += 1,
        }
    }
    assert!(hits > n / 4, "only {hits} of {n} rays hit");
    assert!(disagree * 10_000 < n, "{disagree} of {n} rays disagree");
}

#[test]
fn an_unevenly_scaled_sphere_is_an_ellipsoid() {
    let (a, b, c) = (2.0f32, 0.5, 1.2);
    let sc = built(&format!(
        r#"<shape type="shapegroup" id="g"><shape type="sphere"/></shape>
           <shape type="instance"><ref id="g"/><transform name="to_world"><scale x="{a}" y="{b}" z="{c}"/></transform></shape>"#
    ));
    let mut s = Sampler::new(6, 0);
    let mut hits = 0;
    for _ in 0..20_000 {
        let ray = random_ray(&mut s);
        // Analytic: |(o + t d) / (a, b, c)|^2 = 1.
        let inv = Vec3::new(1.0 / a, 1.0 / b, 1.0 / c);
        let (o, d) = ((ray.o * inv).as_dvec3(), (ray.d * inv).as_dvec3());
        let (qa, qb, qc) = (d.length_squared(), 2.0 * o.dot(d), o.length_squared() - 1.0);
        let disc = qb * qb - 4.0 * qa * qc;
        let t = (disc >= 0.0)
            .then(|| {
                let r = disc.sqrt();
                [(-qb - r) / (2.0 * qa), (-qb + r) / (2.0 * qa)]
                    .into_iter()
                    .find(|&t| t > 0.0)
            })
            .flatten();
        let its = sc.intersect(&ray);
        match (t, its) {
            (Some(t), Some(its)) => {
                hits += 1;
                assert!(
                    (its.t as f64 - t).abs() < 1e-4 * t.max(1.0),
                    "t {} vs {t}",
                    its.t
                );
                let p = its.p;
                let n = Vec3::new(p.x / (a * a), p.y / (b * b), p.z / (c * c)).normalize();
                assert!(its.ng.dot(n) > 0.9999, "normal {} vs {n}", its.ng);
                assert!(its.shading.n.dot(n) > 0.9999);
            }
            (None, None) => {}
            // Tangent rays.
            (Some(_), None) | (None, Some(_)) => assert!(disc.abs() < 1e-3),
        }
    }
    assert!(hits > 1000);
}

#[test]
fn spawned_rays_leave_instanced_surfaces() {
    // Far from the origin, scaled unevenly, rotated and mirrored: rays
    // leaving the outside of the instanced closed mesh hit nothing.
    for (k, placement) in [
        r#"<scale x="3" y="1" z="0.5"/><rotate y="1" angle="33"/><translate x="1000" y="-500" z="200"/>"#,
        r#"<scale x="-200" y="150" z="100"/><rotate x="1" angle="-71"/><translate x="3e4" z="-1e4"/>"#,
    ]
    .iter()
    .enumerate()
    {
        let sc = built(&format!(
            r#"<shape type="shapegroup" id="g"><shape type="cube"/><shape type="sphere"><point name="center" value="3, 0, 0"/></shape></shape>
               <shape type="instance"><ref id="g"/><transform name="to_world">{placement}</transform></shape>"#
        ));
        let centre = sc.bounds.center();
        let mut s = Sampler::new(7 + k as u64, 0);
        let mut self_hits = 0;
        let mut n = 0;
        for _ in 0..20_000 {
            let far = centre + warp::square_to_uniform_sphere(s.next_2d()) * sc.scene_radius * 4.0;
            let Some(its) = sc.intersect(&Ray::new(far, (centre - far).normalize())) else {
                continue;
            };
            n += 1;
            let out = its
                .shading
                .to_world(warp::square_to_cosine_hemisphere(s.next_2d()));
            let out = if out.dot(its.ng) < 0.0 { -out } else { out };
            // Outward from the outside: only the other shape could be met,
            // and never at the spawn point.
            if let Some(h) = sc.intersect(&Ray::new(its.spawn(out), out)) {
                if h.shape == its.shape && h.t < 1e-3 * sc.scene_radius {
                    self_hits += 1;
                }
            }
        }
        assert!(n > 1000);
        assert_eq!(self_hits, 0, "placement {k}: {self_hits} of {n} spawned rays hit their own surface");
    }
}

#[test]
fn instancing_errors() {
    assert_err(
        &scene(
            "<shape type=\"shapegroup\" id=\"g\">\n  <shape type=\"sphere\"><emitter type=\"area\"/></shape></shape>",
        ),
        5,
        3,
        &["emitter", "shapegroup"],
    );
    assert_err(
        &scene(
            "<shape type=\"shapegroup\" id=\"g\"><shape type=\"sphere\"/></shape>\n<shape type=\"shapegroup\" id=\"h\">\n  <shape type=\"instance\"><ref id=\"g\"/></shape></shape>",
        ),
        6,
        3,
        &["nested instancing"],
    );
    assert_err(
        &scene("<shape type=\"instance\">\n</shape>"),
        4,
        1,
        &["shapegroup", "<ref"],
    );
    assert_err(
        &scene(
            "<bsdf type=\"diffuse\" id=\"b\"/>\n<shape type=\"instance\">\n  <ref id=\"b\"/></shape>",
        ),
        6,
        3,
        &["only a reference to a shapegroup"],
    );
    assert_err(
        &scene(
            "<shape type=\"shapegroup\" id=\"g\"/><shape type=\"shapegroup\" id=\"h\"/>\n<shape type=\"instance\"><ref id=\"g\"/>\n  <ref id=\"h\"/></shape>",
        ),
        6,
        3,
        &["only one shapegroup"],
    );
}

#[test]
fn empty_groups_and_unused_groups_load() {
    let sc = built(
        r#"<shape type="shapegroup" id="empty"/>
           <shape type="shapegroup" id="unused"><shape type="sphere"/></shape>
           <shape type="instance"><ref id="empty"/></shape>"#,
    );
    assert!(sc
        .intersect(&Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z))
        .is_none());
}
