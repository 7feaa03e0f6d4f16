#!/usr/bin/env bash
# Reprints the figures of BENCHMARKS.md that quick commands give, section by section, each
# line named as the row it regenerates. Usage, from anywhere in the repository:
#   bash host/benches/figures.sh [machine] [device] [host] [criterion]   (default: machine device)
# device: the images' sizes (llvm-size), the self-test under QEMU -icount and the QEMU tests
#         that print instructions per sample and stack (about 3 min of QEMU);
# host:   a release `supine` on generated rides (`/usr/bin/time -v`: CPU and peak memory);
# criterion: `cargo bench -p supine-host --bench identification` (a release build of the benches).
# The identification speed-up against SciPy has its own script: host/benches/fit_robustness.py.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
sections=("$@")
[ ${#sections[@]} -eq 0 ] && sections=(machine device)

machine() {
    echo "== machine"
    echo "cores: $(nproc)"
    grep -m1 "model name" /proc/cpuinfo
    qemu-system-arm --version | head -1
    rustc --version
    echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
}

# The lines of a QEMU test's output that carry figures.
qemu_test() {
    local test=$1 filter=$2 pattern=$3
    cargo test --quiet -p supine-qemu-tests --test qemu -- --nocapture --test-threads 1 \
        "$test::$filter" 2>&1 | grep -E "$pattern"
}

device() {
    cargo fw --quiet
    local out=target/firmware/thumbv7em-none-eabihf/fw
    local llvm_size
    llvm_size=$(ls "$(rustc --print sysroot)"/lib/rustlib/*/bin/llvm-size)
    echo "== device: flash (text + data) and static RAM (data + bss), bytes"
    "$llvm_size" "$out/supine-firmware" "$out/panic_reset" "$out/selftest"

    echo "== device: self-test under -icount shift=0 (instructions, not cycles)"
    timeout 120 qemu-system-arm -machine mps2-an386 -nographic -monitor none \
        -semihosting-config enable=on,target=native -icount shift=0,align=off,sleep=off \
        -serial null -kernel "$out/selftest" |
        grep -E '^(multiply_adds_per_sample|instructions_per_step|exposure_stage_instructions_per_sample|pipeline_instructions_per_sample|telemetry_frame_instructions|sqrtf_instructions|vsqrt_[a-z_]+|stack_[a-z_]+|selftest: ok)'

    echo "== device: pipeline per sample, 4 s ride, telemetry every 5th sample (replay_cli.rs)"
    qemu_test replay_cli the_pipeline_fits '^(instructions_per_sample|stack_used_bytes):'
    echo "== device: telemetry every sample, 60 s at 500 Hz (monitor.rs)"
    qemu_test monitor device_matches_the_host_reference \
        '(instructions_per_sample|stack_used_bytes|head max|exposure max)'
    echo "== device: 20 s rough road, shipping telemetry, input stream off / on (monitor_reanalysis.rs)"
    qemu_test monitor_reanalysis the_input_stream_costs '^stream (on|off):'
    echo "== device: stack after a committed upload (upload.rs)"
    qemu_test upload a_signed_upload '^stack_used_bytes:'
}

# Runs a release `supine` under /usr/bin/time and prints its CPU time and peak memory.
timed() {
    local what=$1
    shift
    /usr/bin/time -f "$what: %U s user, %e s wall, %M KB peak" "$@" >/dev/null
}

host() {
    cargo build --quiet --release -p supine-host --bin supine
    local supine=target/release/supine dir
    dir=$(mktemp -d)
    trap 'rm -rf "$dir"' RETURN
    echo "== host: release supine, rides of rough road at 500 Hz"
    for p in ambulance helicopter rough-road; do
        "$supine" ride --profile "$p" --duration-s 1200 --seed 5 --out "$dir/leg_$p.csv"
    done
    timed "report, one-hour mission of three 20 min legs" "$supine" report \
        --preset paper-litter --input "$dir/leg_ambulance.csv" --input "$dir/leg_helicopter.csv" \
        --input "$dir/leg_rough-road.csv" --out "$dir/mission" --json
    "$supine" ride --profile rough-road --duration-s 3600 --seed 5 --out "$dir/r1h.csv"
    timed "exposure, 1 h ride" "$supine" exposure --preset paper-litter --input "$dir/r1h.csv" --json
    timed "report, 1 h ride" "$supine" report --preset paper-litter --input "$dir/r1h.csv" \
        --out "$dir/r1h" --json
    timed "demo, default ride (device in QEMU)" "$supine" demo --out "$dir/demo"
}

criterion() {
    echo "== criterion (release), identification"
    cargo bench --quiet -p supine-host --bench identification 2>&1 | grep -E -B1 'time:' | grep -vE '^(--)?$'
}

for s in "${sections[@]}"; do
    case $s in
    machine | device | host | criterion) "$s" ;;
    *)
        echo "unknown section $s: expected machine, device, host or criterion" >&2
        exit 2
        ;;
    esac
done
