//! Materials: the scene's `<bsdf>` trees with textured parameters. At a hit a material evaluates
//! its textures and writes plain-valued [`BsdfNode`]s into the per-thread arena.

use crate::bsdf::{BsdfArena, BsdfNode, Diffuse};
use crate::geometry::SurfaceInteraction;
use crate::texture::Texture;

/// Index of a texture in [`Materials::textures`].
pub type TexId = u32;
/// Index of a material node in [`Materials::nodes`].
pub type MatId = u32;

#[derive(Clone, Debug)]
pub enum MaterialNode {
    Diffuse { reflectance: TexId },
    TwoSided { front: MatId, back: MatId },
}

/// All materials and textures of a scene.
#[derive(Clone, Debug, Default)]
pub struct Materials {
    pub nodes: Vec<MaterialNode>,
    pub textures: Vec<Texture>,
}

impl Materials {
    pub fn add_texture(&mut self, t: Texture) -> TexId {
        self.textures.push(t);
        (self.textures.len() - 1) as TexId
    }

    pub fn add_node(&mut self, n: MaterialNode) -> MatId {
        self.nodes.push(n);
        (self.nodes.len() - 1) as MatId
    }

    /// Build the BSDF of material `id` at `si` into `arena`; returns the root node index.
    pub fn build(&self, id: MatId, si: &SurfaceInteraction, arena: &mut BsdfArena) -> u32 {
        match &self.nodes[id as usize] {
            MaterialNode::Diffuse { reflectance } => {
                let r = self.textures[*reflectance as usize].eval(si.uv);
                arena.push(BsdfNode::Diffuse(Diffuse { reflectance: r }))
            }
            MaterialNode::TwoSided { front, back } => {
                let f = self.build(*front, si, arena);
                let b = if front == back {
                    f
                } else {
                    self.build(*back, si, arena)
                };
                arena.push(BsdfNode::TwoSided { front: f, back: b })
            }
        }
    }
}
