//! Scene loading and its parts: the XML parser and loader, geometry (meshes, shapes, Embree hits),
//! textures, emitters and image output. One test crate for the theme.

#[path = "../common/mod.rs"]
mod common;

mod curves;
mod emitters;
mod geometry;
mod hair;
mod hostile;
mod output;
mod plugins;
mod texture;
mod xml_parse;
