//! What a load is asked to do beyond the file itself: `-D` definitions and the
//! `--normal-mapping` conversion of every normal map (decision 6 of `mnm.md`).

use crate::bsdf::mnm::facets::Microgeometry;
use crate::bsdf::mnm::{Evaluation, Tangent};
use crate::budget::Budget;

/// Options of a load: `-D key=value` definitions from the command line and the model the
/// normal maps become.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    pub defines: Vec<(String, String)>,
    /// `--normal-mapping`: keep the normal maps as written or convert them all to one model.
    pub normal_mapping: NormalMapping,
    /// The memory budget (`--max-memory`) images, meshes and the expanded XML are checked
    /// against before they are allocated; the render goes on with the same budget.
    pub budget: Budget,
}

/// Which normal-mapping model the scene's normal maps use (decision 6 of `mnm.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum NormalMapping {
    /// `normalmap` and `microfacet_normalmap` as the file says.
    #[default]
    AsWritten,
    /// Every `microfacet_normalmap` becomes a plain `normalmap` (both flags false).
    Classic,
    /// Every `normalmap` becomes a `microfacet_normalmap` with the decisions page's defaults.
    Microfacet,
    /// Every normal map (`normalmap` or `microfacet_normalmap`) becomes a `microfacet_normalmap`
    /// with this microgeometry, tangent and evaluation (other parameters as written, or
    /// defaults): the modes `groove bench` compares.
    Forced(MnmMode),
}

/// The microfacet normal-mapping choices a [`NormalMapping::Forced`] imposes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MnmMode {
    pub geometry: Microgeometry,
    pub tangent: Tangent,
    pub evaluation: Evaluation,
}

impl NormalMapping {
    /// Every value `--normal-mapping` accepts, in the order `groove bench` renders them.
    pub const NAMES: [&'static str; 10] = [
        "classic",
        "explicit",
        "explicit4",
        "compensated",
        "auto",
        "walk-mirror",
        "walk-same",
        "vgroove",
        "ugroove",
        "microfacet",
    ];

    /// `classic`, `microfacet`, `as_written`, or a forced mode: `explicit` (sawtooth, mirror
    /// wall, the paper's closed form), `explicit4` (the same with the complete first order, four
    /// paths), `compensated` (sawtooth, mirror wall, the complete first order plus the tabulated
    /// rank-1 remainder of the walk), `auto` (the same microsurface, per shading point
    /// `compensated` where its misplaced energy against the walk is small, else `walk-mirror`,
    /// blended between), `walk-mirror` (sawtooth, mirror wall, random walk: the
    /// paper's model), `walk-same` (sawtooth, same-material wall, random walk: the default
    /// model), `vgroove`, `ugroove` (fill 0.5; random walk).
    pub fn parse(s: &str) -> Option<NormalMapping> {
        let forced = |geometry, tangent, evaluation| {
            Some(NormalMapping::Forced(MnmMode {
                geometry,
                tangent,
                evaluation,
            }))
        };
        use Evaluation::*;
        match s {
            "classic" => Some(NormalMapping::Classic),
            "microfacet" => Some(NormalMapping::Microfacet),
            "as_written" | "as-written" => Some(NormalMapping::AsWritten),
            "explicit" => forced(Microgeometry::Sawtooth, Tangent::Mirror, Explicit),
            "explicit4" => forced(Microgeometry::Sawtooth, Tangent::Mirror, ExplicitComplete),
            "compensated" => forced(Microgeometry::Sawtooth, Tangent::Mirror, Compensated),
            "auto" => forced(Microgeometry::Sawtooth, Tangent::Mirror, Auto),
            "walk-mirror" => forced(Microgeometry::Sawtooth, Tangent::Mirror, RandomWalk),
            "walk-same" => forced(Microgeometry::Sawtooth, Tangent::Same, RandomWalk),
            "vgroove" => forced(Microgeometry::VGroove, Tangent::Same, RandomWalk),
            "ugroove" => forced(
                Microgeometry::UGroove { fill: 0.5 },
                Tangent::Same,
                RandomWalk,
            ),
            _ => None,
        }
    }
}
