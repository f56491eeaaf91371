#!/usr/bin/env bash
# Cross-compiles the C of every example model for a Cortex-M4F
# (docs/embedded.md, "Cross-compiling for a Cortex-M4F"): `qpv codegen
# --lang c` in f64 and f32, then
#   arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -Os
# and, for comparison, the host's cc -Os. Prints the `.text` size of every
# object, the M4F object's `.rodata` with and without the certificate text
# (`-D<M>_NO_CERTIFICATE`), and fails if an f32 object references a
# double-precision helper (`__aeabi_d*`, found by nm) or a file does not
# compile.
#
# Usage: scripts/cortex-m.sh [MODEL.qpv ...]     (default: examples/*.qpv)
# Environment: QPV (the qpv binary; default: cargo build --release),
# QPV_TIMEOUT (seconds per design, default 300), OUT (work directory).
# Without arm-none-eabi-gcc it says so and exits 2 (Debian/Ubuntu:
# apt-get install gcc-arm-none-eabi).
set -euo pipefail
cd "$(dirname "$0")/.."

CROSS=${CROSS:-arm-none-eabi-gcc}
if ! command -v "$CROSS" >/dev/null; then
    echo "cortex-m.sh: $CROSS not found; install it with" >&2
    echo "    apt-get install gcc-arm-none-eabi     (Debian/Ubuntu; about 410 MB download)" >&2
    exit 2
fi
NM=${NM:-arm-none-eabi-nm}
SIZE=${SIZE:-arm-none-eabi-size}
HOSTCC=${HOSTCC:-cc}
ARMFLAGS="-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -Os"
WARN="-std=c99 -Wall -Wextra -Werror -pedantic"
WARN32="-Wdouble-promotion -Wfloat-conversion"
if [[ -z "${QPV:-}" ]]; then
    cargo build --release --bin qpv >&2
    QPV=target/release/qpv
fi
OUT=${OUT:-$(mktemp -d)}
TIMEOUT=${QPV_TIMEOUT:-300}
models=("$@")
[[ ${#models[@]} -gt 0 ]] || models=(examples/*.qpv)

status=0
printf '%-22s %-5s %10s %10s %10s %10s  %s\n' model float x86-64 cortex-m4f m4f-rodata "no-cert" \
    "double helpers (f32 must have none)"
for f in "${models[@]}"; do
    base=$(basename "$f" .qpv)
    for float in f64 f32; do
        dir="$OUT/$base-$float"
        mkdir -p "$dir"
        if ! timeout "$TIMEOUT" "$QPV" codegen "$f" --lang c --float "$float" --out "$dir" \
            >"$dir/codegen.log" 2>&1; then
            printf '%-22s %-5s %s\n' "$base" "$float" \
                "no certified design to export ($(tail -n 1 "$dir/codegen.log"))"
            continue
        fi
        src=$(ls "$dir"/*.c)
        flags="$WARN"
        [[ $float == f32 ]] && flags="$WARN $WARN32"
        # shellcheck disable=SC2086
        up=$(basename "$src" .c | tr '[:lower:]' '[:upper:]')
        if ! $CROSS $ARMFLAGS $flags -c "$src" -o "$dir/m4.o" 2>"$dir/m4.log" \
            || ! $CROSS $ARMFLAGS $flags "-D${up}_NO_CERTIFICATE" -c "$src" -o "$dir/m4-nocert.o" \
                2>>"$dir/m4.log" \
            || ! $HOSTCC -Os $flags -c "$src" -o "$dir/host.o" 2>"$dir/host.log"; then
            printf '%-22s %-5s %s\n' "$base" "$float" "DOES NOT COMPILE (see $dir/*.log)"
            status=1
            continue
        fi
        m4=$($SIZE -A "$dir/m4.o" | awk '$1 == ".text" { print $2 }')
        ro=$($SIZE -A "$dir/m4.o" | awk '$1 == ".rodata" { s += $2 } END { print s + 0 }')
        ro_nc=$($SIZE -A "$dir/m4-nocert.o" | awk '$1 == ".rodata" { s += $2 } END { print s + 0 }')
        host=$(size -A "$dir/host.o" | awk '$1 == ".text" { print $2 }')
        helpers=$($NM -u "$dir/m4.o" | awk '{ print $2 }' | grep '^__aeabi_d' | tr '\n' ' ' || true)
        printf '%-22s %-5s %10s %10s %10s %10s  %s\n' "$base" "$float" "$host" "$m4" "$ro" "$ro_nc" \
            "${helpers:-none}"
        if [[ $float == f32 && -n $helpers ]]; then
            echo "error: the f32 object of $base references double-precision helpers: $helpers" >&2
            status=1
        fi
    done
done
exit $status
