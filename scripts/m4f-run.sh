#!/usr/bin/env bash
# Runs generated f32 observers on an emulated Cortex-M4F (QEMU mps2-an386,
# hard float, semihosting) and on the host (docs/embedded.md, "Run on an
# emulated Cortex-M4F"). For each model:
#   1. `qpv codegen --lang c --float f32` (the observer) and the f64 export
#      of a renamed copy (the plant, in double);
#   2. scripts/m4f/driver.c built twice at -std=c99: for the host (cc -O2)
#      and for the M4F (arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb
#      -mfloat-abi=hard -mfpu=fpv4-sp-d16 -Os, scripts/m4f/startup.c and
#      scripts/m4f/mps2-an386.ld, no C library start files);
#   3. both run; each checks, at every step, the observer's error against
#      the certified f32 floor from the header (exit 1 if above), and the
#      two outputs (the estimates' float bits every 500 steps, a hash of
#      every step's bits, the largest error's bits) must be identical.
# Prints the .text and .rodata of the observer's M4F object (-Os) with and
# without the certificate text, and the time taken.
#
# Usage: scripts/m4f-run.sh [--install] [MODEL.qpv[:X0_SCALE] ...]
#   default: examples/paper.qpv examples/lorenz.qpv:40 tests/fixtures/paper_sampled.qpv
#   X0_SCALE scales the plant's start (0.0117, -0.0049, 0.0039) into the
#   model's state bound.
#   --install: apt-get install the tools if they are missing (as root,
#   Debian: gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm,
#   --no-install-recommends); without it, missing tools are an error (exit 2).
#   --install-only: the same install, then exit (CI runs it before the
#   tests, so that the C tests cross-compile for the M4F too).
# Environment: QPV (the qpv binary; default target/release/qpv, built if
# absent), OUT (work directory), HOSTCC (default cc), STEPS (default 4000).
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)

install=0
only_install=0
if [[ ${1:-} == --install ]]; then
    install=1
    shift
elif [[ ${1:-} == --install-only ]]; then
    install=1
    only_install=1
    shift
fi
PACKAGES=(gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm)
have_tools() {
    command -v arm-none-eabi-gcc >/dev/null && command -v qemu-system-arm >/dev/null \
        && [[ -n $(arm-none-eabi-gcc -print-file-name=libc.a | grep /) ]] \
        && [[ -f $(arm-none-eabi-gcc -print-file-name=libc.a) ]]
}
if ! have_tools; then
    if [[ $install == 0 ]]; then
        echo "m4f-run.sh: arm-none-eabi-gcc, newlib or qemu-system-arm missing; install with" >&2
        echo "    apt-get install --no-install-recommends ${PACKAGES[*]}" >&2
        echo "or run scripts/m4f-run.sh --install as root" >&2
        exit 2
    fi
    t0=$(date +%s)
    sudo=()
    [[ $(id -u) == 0 ]] || sudo=(sudo)
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q >/dev/null
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive \
        apt-get install -y -q --no-install-recommends "${PACKAGES[@]}" >/dev/null
    echo "m4f-run.sh: installed ${PACKAGES[*]} in $(( $(date +%s) - t0 )) s"
else
    echo "m4f-run.sh: tools already installed ($(arm-none-eabi-gcc -dumpversion), $(qemu-system-arm --version | head -n 1))"
fi
[[ $only_install == 0 ]] || exit 0

if [[ -z "${QPV:-}" ]]; then
    [[ -x target/release/qpv ]] || cargo build --release --bin qpv >&2
    QPV=target/release/qpv
fi
OUT=${OUT:-$(mktemp -d)}
HOSTCC=${HOSTCC:-cc}
STEPS=${STEPS:-4000}
H=1e-3f
ARM=(-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16)
WARN=(-std=c99 -Wall -Wextra -Werror -pedantic)
WARN32=(-Wdouble-promotion -Wfloat-conversion)
models=("$@")
[[ ${#models[@]} -gt 0 ]] || models=(examples/paper.qpv examples/lorenz.qpv:40 tests/fixtures/paper_sampled.qpv)

status=0
t_run=$(date +%s)
printf '%-16s %-34s %-10s %-10s %-10s %s\n' model step "floor" ".text" ".rodata" ".rodata without CERTIFICATE"
for spec in "${models[@]}"; do
    file=${spec%%:*}
    scale=1.0
    [[ $spec == *:* ]] && scale=${spec##*:}
    base=$(basename "$file" .qpv)
    dir="$OUT/$base"
    rm -rf "$dir"
    mkdir -p "$dir/f32" "$dir/f64"
    if ! "$QPV" codegen "$file" --lang c --float f32 --out "$dir/f32" >"$dir/codegen.log" 2>&1; then
        echo "$base: qpv codegen --float f32 failed:" >&2
        cat "$dir/codegen.log" >&2
        status=1
        continue
    fi
    header=$(ls "$dir"/f32/*.h)
    m=$(basename "$header" .h)
    up=$(tr '[:lower:]' '[:upper:]' <<<"$m")
    # the plant in double: the f64 export of the same model under another name
    sed "0,/model[[:space:]]\+$m\b/s//model ${m}64/" "$file" >"$dir/${m}64.qpv"
    if ! "$QPV" codegen "$dir/${m}64.qpv" --model "${m}64" --lang c --float f64 \
        --out "$dir/f64" >>"$dir/codegen.log" 2>&1; then
        echo "$base: the f64 export (the plant) failed:" >&2
        cat "$dir/codegen.log" >&2
        status=1
        continue
    fi
    defs=(-I "$dir/f32" -I "$dir/f64" "-DM32=$m" "-DUP32=$up" "-DM64=${m}64"
        "-DHDR32=\"$m.h\"" "-DHDR64=\"${m}64.h\"" "-DH=$H" "-DX0_SCALE=$scale" "-DSTEPS=$STEPS")
    grep -q "_SAMPLE_PERIOD;" "$header" && defs+=(-DSAMPLED)
    src32="$dir/f32/$m.c"
    src64="$dir/f64/${m}64.c"
    # host
    $HOSTCC "${WARN[@]}" "${WARN32[@]}" -O2 -c "$src32" -o "$dir/host32.o"
    $HOSTCC "${WARN[@]}" -O2 "${defs[@]}" scripts/m4f/driver.c "$dir/host32.o" "$src64" \
        -o "$dir/host" -lm
    # Cortex-M4F
    arm-none-eabi-gcc "${ARM[@]}" "${WARN[@]}" "${WARN32[@]}" -Os -c "$src32" -o "$dir/m4f32.o"
    arm-none-eabi-gcc "${ARM[@]}" "${WARN[@]}" -Os -DNDEBUG "-D${up}_NO_CERTIFICATE" \
        "${WARN32[@]}" -c "$src32" -o "$dir/m4f32-nocert.o"
    arm-none-eabi-gcc "${ARM[@]}" "${WARN[@]}" -Os "${defs[@]}" scripts/m4f/driver.c \
        scripts/m4f/startup.c "$dir/m4f32.o" "$src64" -nostartfiles -T scripts/m4f/mps2-an386.ld \
        --specs=nosys.specs -Wl,--gc-sections -o "$dir/m4f.elf" -lm
    host_rc=0
    "$dir/host" >"$dir/host.out" || host_rc=$?
    m4f_rc=0
    timeout 300 qemu-system-arm -M mps2-an386 -cpu cortex-m4 -nographic -monitor none -serial none \
        -semihosting-config enable=on,target=native -kernel "$dir/m4f.elf" \
        >"$dir/qemu.log" 2>"$dir/m4f.out" || m4f_rc=$?
    section() { arm-none-eabi-size -A "$1" | awk -v s="$2" '$1 == s { print $2 }'; }
    floor=$(sed -n 's/^certified f32 floor //p' "$dir/host.out")
    step=$(sed -n 's/^step: //p' "$dir/host.out")
    printf '%-16s %-34s %-10s %-10s %-10s %s\n' "$m" "$step" "$floor" \
        "$(section "$dir/m4f32.o" .text)" "$(section "$dir/m4f32.o" .rodata)" \
        "$(section "$dir/m4f32-nocert.o" .rodata)"
    echo "  host: $(tail -n 1 "$dir/host.out") (exit $host_rc)"
    echo "  m4f:  $(tail -n 1 "$dir/m4f.out") (exit $m4f_rc)"
    if [[ $host_rc != 0 || $m4f_rc != 0 ]]; then
        echo "error: $m: the observer's error exceeds the certified floor or the run failed (see $dir)" >&2
        status=1
    fi
    if ! diff -u "$dir/host.out" "$dir/m4f.out" >"$dir/diff.txt"; then
        echo "error: $m: the M4F estimates differ from the host build's bits:" >&2
        head -n 20 "$dir/diff.txt" >&2
        status=1
    else
        echo "  bits: the M4F run equals the host run ($(grep -c '^step ' "$dir/host.out") checkpoints, hash $(sed -n 's/^estimate hash //p' "$dir/host.out"))"
    fi
done
echo "m4f-run.sh: runs took $(( $(date +%s) - t_run )) s, $(( $(date +%s) - start )) s in all"
exit $status
