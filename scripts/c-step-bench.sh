#!/usr/bin/env bash
# Host time per step of the exported C observers (docs/embedded.md,
# "Measured"): `qpv codegen --lang c` of the paper example and the
# manipulator in f64 and f32, compiled with cc -O2, timed over 10⁶ calls of
# step_euler and of step_rk4 (clock_gettime, the best of 5 runs). A
# benchmark: it prints numbers and asserts nothing about them.
#
# Usage: scripts/c-step-bench.sh [MODEL.qpv ...]  (default: the paper example and the manipulator)
# Environment: QPV (default: cargo build --release), HOSTCC (default cc), OUT.
set -euo pipefail
cd "$(dirname "$0")/.."
HOSTCC=${HOSTCC:-cc}
if [[ -z "${QPV:-}" ]]; then
    cargo build --release --bin qpv >&2
    QPV=target/release/qpv
fi
OUT=${OUT:-$(mktemp -d)}
models=("$@")
[[ ${#models[@]} -gt 0 ]] || models=(examples/paper.qpv examples/manipulator.qpv)

printf '%-22s %-5s %14s %14s\n' model float "euler ns/step" "rk4 ns/step"
for f in "${models[@]}"; do
    for float in f64 f32; do
        dir="$OUT/$(basename "$f" .qpv)-$float"
        mkdir -p "$dir"
        "$QPV" codegen "$f" --lang c --float "$float" --out "$dir" >"$dir/codegen.log" 2>&1
        src=$(ls "$dir"/*.c)
        m=$(basename "$src" .c)
        M=$(tr '[:lower:]' '[:upper:]' <<<"$m")
        cat >"$dir/bench.c" <<EOF
#define _POSIX_C_SOURCE 199309L
#include "$m.h"
#include <stdio.h>
#include <time.h>

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* one run of n steps; y, u, θ vary so nothing is hoisted */
static double run(int rk4, long n) {
    ${m}_observer o;
    ${m}_real y[${M}_NY], u[${M}_NU + 1], th[${M}_NTHETA + 1];
    volatile ${m}_real sink;
    long k;
    int i;
    double t0;
    ${m}_init(&o);
    t0 = now();
    for (k = 0; k < n; k++) {
        ${m}_real s = (${m}_real)(k % 1000) * (${m}_real)1e-4;
        for (i = 0; i < ${M}_NY; i++) y[i] = s;
        for (i = 0; i < ${M}_NU; i++) u[i] = s;
        for (i = 0; i < ${M}_NTHETA; i++) th[i] = ${m}_THETA_MIN[i] + s * (${m}_THETA_MAX[i] - ${m}_THETA_MIN[i]);
        if (rk4) ${m}_step_rk4(&o, (${m}_real)1e-3, y, u, th);
        else ${m}_step_euler(&o, (${m}_real)1e-3, y, u, th);
    }
    sink = ${m}_estimate(&o)[0];
    (void)sink;
    return (now() - t0) / (double)n * 1e9;
}

int main(void) {
    double best[2] = {1e300, 1e300};
    int r, k;
    for (r = 0; r < 5; r++)
        for (k = 0; k < 2; k++) {
            double t = run(k, 1000000L);
            if (t < best[k]) best[k] = t;
        }
    printf("%.1f %.1f\n", best[0], best[1]);
    return 0;
}
EOF
        "$HOSTCC" -std=c99 -O2 -I"$dir" "$dir/bench.c" "$src" -o "$dir/bench" -lm
        read -r eu rk < <("$dir/bench")
        printf '%-22s %-5s %14s %14s\n' "$m" "$float" "$eu" "$rk"
    done
done
