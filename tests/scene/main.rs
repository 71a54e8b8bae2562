//! Scene loading and its parts: the XML parser and loader, geometry (meshes, shapes, Embree hits),
//! textures, emitters and image output. One test crate for the theme.

#[path = "../common/mod.rs"]
mod common;

mod curves;
mod cylinder_quirks;
mod degenerate;
mod emitters;
mod float_images;
mod geometry;
mod hair;
mod hostile;
mod instances;
mod media;
mod media_albedo;
mod media_hetero;
mod media_issue21;
mod mesh_attribute;
mod output;
mod packets;
mod plugins;
mod projector;
mod ptracer;
mod rotate_axis;
mod sdfgrid;
mod texture;
mod tier_a;
mod transform_quirks;
mod volpathmis;
mod xml_parse;
