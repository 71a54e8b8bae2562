#!/bin/sh
# Runs every target for SECS seconds (default 180), or until RUNS executions (default: no limit),
# with the memory and per-input time limits
# of fuzz/README.md, one after the other, on the binaries `cargo +nightly fuzz build -s none`
# made (the same as `cargo +nightly fuzz run -s none TARGET corpus/TARGET seeds/TARGET -- ...`).
# Logs go to logs/TARGET.log.
cd "$(dirname "$0")" || exit 1
SECS=${SECS:-180}
RUNS=${RUNS:--1}
BIN=target/x86_64-unknown-linux-gnu/release
mkdir -p logs
for t in ${TARGETS:-xml_load obj ply serialized bitmap define}; do
    mkdir -p corpus/$t artifacts/$t
    "$BIN/$t" corpus/$t seeds/$t -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=10 \
        -max_total_time="$SECS" -runs="$RUNS" -max_len=65536 -artifact_prefix=artifacts/$t/ -print_final_stats=1 \
        > logs/$t.log 2>&1
    echo "$t exit $?" >> logs/summary.txt
done
