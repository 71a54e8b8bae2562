//! The lane abstraction (`groove::lane`, issue 16 item 2):
//! - `bits`: every 8-wide function equals the 1-wide one bit for bit in every lane, over 10⁷
//!   random inputs per polynomial function and for PCG32, 2·10⁵ per composite kernel (random bit
//!   patterns, the function's domain, edge cases in every lane position);
//! - `accuracy`: the polynomial functions against f64 `std`, in ulps (2·10⁵ inputs per range),
//!   and their special values;
//! - `scalar`: width 1 against groove's scalar code where they must agree (frames, Fresnel,
//!   microfacets, PCG32) or nearly agree (warps);
//! - `avx512`: the experimental 16-wide AVX-512 type equals width 1 bit for bit (skipped
//!   without AVX-512);
//! - `beckmann`: the f32 visible-Beckmann sampler against its f64 reference (`beckmann_ref`);
//! - `pcg_ops`, `lookup`: the per-width PCG32 operations and small-table lookups against plain
//!   scalar references (every state class; edge floats and out-of-range indices), and the
//!   window gather of `Vec3` rows (`Avx2::gather3_window`), and the rows of three words
//!   (`Lane::gather3`, `Avx2::gather3_u32`) at every table length's edge;
//! - `masks`: masks from booleans and from bits, and back to bits, at width 8 and 16 (every
//!   pattern, bits above the width ignored);
//! - `rows4`: the 8-wide rows-of-4 transposes move every bit (edge floats, NaN payloads).
//! - `compress`: the 8-wide compress of path ids (`Avx2::compress_store`, every mask), its
//!   permutation alone (`Avx2::compress_index`) and the 2-D points' columns
//!   (`Avx2::vec2_columns`) against scalar references.
//! - `store_at`: the write-back of gathered 64-bit values (`Wide::store_u64_at`) against a
//!   scalar reference at width 8 and 16 (repeated and out-of-range indices).
//! - `state_gathers`: the path states' index products, throughputs and depths in lanes
//!   (`Avx2::gather_eta`, `Avx2::gather_throughput`, `Avx2::gather_depth`) against the fields
//!   (every bit, indices clamped).
//! - `ray_row`: one ray as a row of 8 floats (`Avx2::ray_row`, tier A's packets read in place)
//!   against its fields, and 8 rows against `Avx2::ray_fields` (every bit); 16 rays read in
//!   place (`Avx512::ray_fields16_at`) against their fields and `Avx512::ray_fields16`.
//! - `permute`: nibbles of a word in lanes (`Avx2::nibbles`) and the permute by lane index
//!   (`F32x8::permute`) against scalar references (edge floats, NaN payloads, indices with high
//!   bits set, negative and extreme).
//! - `i128_sums`: the film's eight rows of 128-bit addends summed in registers
//!   (`I128x4::sum8`), and two or four of them (`I128x4::sum`), against plain wrapping `i128`
//!   sums (carries in every position).
//! - `entries`: a column's 8 entries at 8 ids with one bounds check (`Avx2::entries_at`,
//!   `Avx2::for_each_at_mut`) against indexing (edge and repeated ids; the panic before writes).
//! - `whole_pixels`: the stream keys of four pixels in one register (`U64x4`, `stream_key`)
//!   and spread to eight lanes (`U64x4::spread`), the u32 lanes widened (`U64x8::from_u32`),
//!   and the batch fill's streams of a chunk of whole pixels
//!   (`sampler::for_whole_pixels_x8`) against `Sampler::for_sample` path by path.
//!
//! Run in release mode: `cargo test --release --test lane`. The input count per function is
//! `GROOVE_LANE_N` (default 10⁷; setting it also raises the composite kernels to it); the sweep
//! over random bit patterns only is `#[ignore]`d:
//! `GROOVE_LANE_N=100000000 cargo test --release --test lane -- --include-ignored`.
//! On a CPU without AVX2/FMA the 8-wide half is skipped and says so.

mod accuracy;
mod avx512;
mod beckmann;
mod beckmann_ref;
mod bits;
mod compress;
mod entries;
mod harness;
mod i128_sums;
mod lookup;
mod masks;
mod pcg_ops;
mod permute;
mod ray_row;
mod rows4;
mod scalar;
mod state_gathers;
mod store_at;
mod whole_pixels;
