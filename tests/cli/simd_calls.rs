//! The release binary calls no SIMD intrinsic out of line. An intrinsic such as
//! `_mm256_mul_ps` is one instruction when it is inlined into a function compiled with its
//! target features (the lane code's `run_avx2`/`run_avx512`); a closure or an `impl Fn` shim
//! that LLVM leaves out of line is compiled without them, and every intrinsic in it then
//! becomes a call (the stream's plastic kernel made ~1,000 such calls per chunk through an
//! `Option::map` closure; the lane bench's 8-wide warps ran ~90x slower for the same reason:
//! `docs/bench/README.md`, fourteenth session). Checked on the disassembly (`objdump`, from
//! binutils, which the Rust toolchain's linker needs anyway). Debug builds call every
//! intrinsic out of line, so the check runs on release builds only (the README's test command).

use std::collections::BTreeMap;
use std::process::Command;

#[test]
fn no_intrinsic_is_called_out_of_line() {
    if cfg!(debug_assertions) {
        eprintln!("skipped: a debug build calls every intrinsic out of line (run with --release)");
        return;
    }
    let bin = assert_cmd::cargo::cargo_bin("groove");
    let out = Command::new("objdump")
        .args(["-d", "--no-show-raw-insn", "-C"])
        .arg(&bin)
        .output()
        .expect("objdump (binutils) runs");
    assert!(out.status.success(), "objdump failed on {}", bin.display());
    let text = String::from_utf8_lossy(&out.stdout);
    let mut callers: BTreeMap<String, usize> = BTreeMap::new();
    let mut function = String::new();
    let mut functions = 0;
    for line in text.lines() {
        // A function's header: `0000000000191830 <name>:`.
        if let Some(name) = line.strip_suffix(">:").and_then(|l| l.split_once(" <")) {
            function = name.1.to_string();
            functions += 1;
        } else if line.contains("call") && line.contains("core::core_arch::") {
            // The standard library's CPU detection calls `__cpuid` itself; nothing else may.
            if !function.starts_with("std_detect::") {
                *callers.entry(function.clone()).or_default() += 1;
            }
        }
    }
    assert!(
        functions > 1000,
        "no disassembly read from {}",
        bin.display()
    );
    assert!(
        callers.is_empty(),
        "functions calling SIMD intrinsics out of line (calls per function): {callers:#?}\n\
         Keep lane code out of closures and `impl Fn` arguments (`Option::map`, `array::from_fn`, \
         …): write loops and `match`es inside the SIMD function."
    );
}
