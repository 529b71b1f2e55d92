//! Integrators: Mitsuba's `path`, `direct` and `volpath` (`volpathmis`
//! too; the differentiable path tracers and the light tracer `ptracer`
//! are rendered with `path`).

use super::{Child, Ctx};
use crate::integrator::{Integrator, PathParams, Strategy};
use crate::load::props::int_in;
use crate::load::props::Props;
use crate::load::xml::SceneNode;
use crate::load::SceneError;

type Result<T> = std::result::Result<T, SceneError>;

impl<'d> Ctx<'d> {
    /// `path` (`integrators/path.cpp`: max_depth -1 = unlimited, rr_depth
    /// 5, hide_emitters false) and `direct` (`direct.cpp`).
    pub(super) fn integrator(&mut self, node: &'d SceneNode) -> Result<Integrator> {
        let ty = self.object_type(
            node,
            &[
                "path",
                "direct",
                "volpath",
                "volpathmis",
                "prb",
                "prb_basic",
                "moment",
                "aov",
                "ptracer",
            ],
            &[
                "depth",
                "stokes",
                "prbvolpath",
                "direct_projective",
                "prb_projective",
            ],
        )?;
        let owner = format!("<integrator type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        if ty == "moment" {
            return self.moment(node, &owner, p, &children);
        }
        if ty == "aov" {
            return self.aov(node, &owner, p, &children);
        }
        self.no_children(&children, &owner)?;
        let hide_emitters = p.get_bool("hide_emitters", false)?;
        let integrator = if ty == "direct" {
            let shading = p.get_int("shading_samples", 1)?;
            let em = p.get_int("emitter_samples", shading)?;
            let bs = p.get_int("bsdf_samples", shading)?;
            if (em, bs) != (1, 1) {
                let name = ["emitter_samples", "bsdf_samples", "shading_samples"]
                    .into_iter()
                    .find(|n| p.has(n))
                    .unwrap_or("emitter_samples");
                p.warn(
                    name,
                    format!(
                        "lente's direct integrator takes one emitter and one BSDF sample per \
                         path (asked for {em} and {bs}); raise sample_count instead"
                    ),
                );
            }
            if hide_emitters {
                // The same estimator as Integrator::Direct, with emitters hidden.
                Integrator::Path {
                    strategy: Strategy::Mis,
                    params: PathParams {
                        max_depth: Some(2),
                        rr_depth: u32::MAX,
                        hide_emitters,
                    },
                }
            } else {
                Integrator::Direct {
                    strategy: Strategy::Mis,
                }
            }
        } else {
            if ty == "ptracer" {
                // How the light tracer batches its particles: nothing to
                // do with the image.
                p.get_int("samples_per_pass", -1)?;
                self.warn(
                    node.pos,
                    "the ptracer integrator (a light tracer) is rendered with lente's path \
                     tracer: the same expected image, with other noise (caustics noisier, \
                     most other light cleaner)",
                );
            } else if ty != "path" && ty != "volpath" && ty != "volpathmis" {
                self.warn(
                    node.pos,
                    format!(
                        "the {ty} integrator is rendered with lente's path tracer (the same \
                         image for scenes without participating media)"
                    ),
                );
            }
            let max_depth = match p.get_int("max_depth", -1)? {
                -1 => None,
                d if (1..=u32::MAX as i64).contains(&d) => Some(d as u32),
                0 => {
                    return Err(p.error(
                        "max_depth",
                        "'max_depth' 0 renders a black image; use 1 (emitters only) or more, \
                         or -1 for unlimited",
                    ))
                }
                d => {
                    return Err(p.error(
                        "max_depth",
                        format!("'max_depth' must be -1 (unlimited) or positive, found {d}"),
                    ))
                }
            };
            let rr_depth = int_in(&mut p, "rr_depth", 5, 1, u32::MAX as i64)? as u32;
            let params = PathParams {
                max_depth,
                rr_depth,
                hide_emitters,
            };
            if ty == "volpath" || ty == "volpathmis" {
                // volpathmis is the same estimator with spectral MIS, which
                // lente's volpath does for every chromatic medium.
                Integrator::VolPath { params }
            } else {
                Integrator::Path {
                    strategy: Strategy::Mis,
                    params,
                }
            }
        };
        p.finish(&mut self.warnings);
        Ok(integrator)
    }

    /// Mitsuba's `aov` integrator: the AOVs of its `aovs` list (Mitsuba's
    /// `NAME:TYPE` pairs, the same names and values) written beside the
    /// image of its nested integrator.
    fn aov(
        &mut self,
        node: &'d SceneNode,
        owner: &str,
        mut p: Props<'d>,
        children: &[Child<'d>],
    ) -> Result<Integrator> {
        let spec = p.get_string("aovs", String::new())?;
        let list: crate::aov::AovList = spec.parse().map_err(|e: String| p.error("aovs", e))?;
        if list.mitsuba().is_empty() {
            return Err(p.error(
                "aovs",
                "'aovs' must list NAME:TYPE pairs, e.g. \"dd:depth,nn:sh_normal\"",
            ));
        }
        p.finish(&mut self.warnings);
        let integrator = self.first_nested_integrator(
            node,
            owner,
            children,
            format!(
                "{owner} without a nested <integrator> renders only AOVs, which lente does \
                 not do: put the integrator of the image inside it (e.g. <integrator \
                 type=\"path\"/>), or use lente render --aov"
            ),
            "lente renders the image of the first integrator inside <integrator \
             type=\"aov\">; this one is ignored",
        )?;
        self.aovs = self
            .aovs
            .union(&list)
            .map_err(|e| self.err(node.pos, format!("{owner}: {e}")))?;
        Ok(integrator)
    }

    /// The first integrator nested in a wrapping one (`aov`, `moment`):
    /// `missing` is the error without one; later ones are ignored with
    /// the warning `ignored`; anything else nested is misplaced.
    fn first_nested_integrator(
        &mut self,
        node: &'d SceneNode,
        owner: &str,
        children: &[Child<'d>],
        missing: String,
        ignored: &str,
    ) -> Result<Integrator> {
        let mut nested = children.iter();
        let Some(first) = nested.next() else {
            return Err(self.err(node.pos, missing));
        };
        if first.node.tag != "integrator" {
            return Err(self.misplaced(first, owner));
        }
        let integrator = self.enter(first, |c| c.integrator(first.node))?;
        for other in nested {
            if other.node.tag != "integrator" {
                return Err(self.misplaced(other, owner));
            }
            self.warn(other.at, ignored.to_string());
        }
        Ok(integrator)
    }

    /// Mitsuba's `moment` wraps integrators and writes each one's image
    /// with its second moment as extra channels. lente renders the first
    /// nested integrator and says that the moments are not written.
    fn moment(
        &mut self,
        node: &'d SceneNode,
        owner: &str,
        p: Props<'d>,
        children: &[Child<'d>],
    ) -> Result<Integrator> {
        p.finish(&mut self.warnings);
        let integrator = self.first_nested_integrator(
            node,
            owner,
            children,
            format!("{owner} needs a nested <integrator> (the one whose moments it records)"),
            "only the first integrator inside <integrator type=\"moment\"> is rendered; this \
             one is ignored",
        )?;
        self.warn(
            node.pos,
            "<integrator type=\"moment\"> renders its nested integrator; lente writes no \
             moment channels"
                .to_string(),
        );
        Ok(integrator)
    }
}
