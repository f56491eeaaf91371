/* The run of scripts/m4f-run.sh: one generated f32 observer (model M32,
 * macros UP32) against the plant of the f64 export of the same model
 * (model M64), built twice from this same source: for the host and for an
 * emulated Cortex-M4F (QEMU mps2-an386, output by semihosting).
 *
 * The plant is the Euler-discretised plant, x_{k+1} = x_k + h f(x_k, θ_k),
 * in double, from x0 (a float value, so the observer starts at exactly x0
 * with <m>_init_at: e_0 = 0). θ_k runs triangle waves inside Θ; y_k and θ_k
 * reach the observer rounded to float. The certified f32 floor bounds
 * lim sup |e_k|; started at e_0 = 0 the recursion behind it keeps |e_k| at
 * or below the floor at every step (docs/embedded.md), so every step is
 * checked: continuous designs with <m>_step_euler at h (floor
 * F32_EULER_FLOOR + F32_EULER_UPDATE_ROUNDING / h), sampled designs
 * (-DSAMPLED) with <m>_step at SAMPLE_PERIOD (floor F32_STEP_FLOOR).
 *
 * Printed: the floor and the largest error (as a number and as the double's
 * bits), the estimate's float bits every 500 steps and an FNV-1a hash of
 * the estimate's bits over every step; the host and the M4F output must be
 * identical (the script diffs them). Exit status 0 only if every step is at
 * or below the floor. */
#include HDR32
#include HDR64
#include <stdint.h>
#include <string.h>

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define F(n) CAT(M32, n)
#define D(n) CAT(M64, n)
#define NX CAT(UP32, _NX)
#define NY CAT(UP32, _NY)
#define NU CAT(UP32, _NU)
#define NTHETA CAT(UP32, _NTHETA)

#ifndef STEPS
#define STEPS 4000
#endif

#if defined(__arm__) && !defined(__linux__)
/* ARM semihosting (QEMU -semihosting-config enable=on,target=native). */
static void out(const char *s) {
    register int r0 __asm__("r0") = 0x04; /* SYS_WRITE0 */
    register const char *r1 __asm__("r1") = s;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
}
#else
#include <stdio.h>
static void out(const char *s) {
    fputs(s, stdout);
}
#endif

/* A line buffer and the few formats needed (no printf on the target). */
static char line[256];
static unsigned pos;

static void put(const char *s) {
    while (*s && pos + 1 < sizeof line) line[pos++] = *s++;
}

static void end_line(void) {
    put("\n");
    line[pos] = '\0';
    out(line);
    pos = 0;
}

static void put_hex(uint64_t v, int digits) {
    char b[17];
    int i;
    for (i = digits - 1; i >= 0; i--) {
        b[i] = "0123456789abcdef"[v & 15u];
        v >>= 4;
    }
    b[digits] = '\0';
    put(b);
}

/* v >= 0 as d.dddde[+-]xx (4 significant digits, truncated). */
static void put_sci(double v) {
    char b[16];
    int e = 0, i, d;
    if (!(v == v)) { put("nan"); return; }
    if (v > 1e300) { put("inf"); return; }
    if (v <= 0.0) { put("0"); return; }
    while (v >= 10.0) { v /= 10.0; e++; }
    while (v < 1.0) { v *= 10.0; e--; }
    for (i = 0; i < 6; i++) {
        if (i == 1) { b[i] = '.'; continue; }
        d = (int)v;
        b[i] = (char)('0' + d);
        v = (v - d) * 10.0;
    }
    b[6] = 'e';
    b[7] = e < 0 ? '-' : '+';
    if (e < 0) e = -e;
    b[8] = (char)('0' + e / 10);
    b[9] = (char)('0' + e % 10);
    b[10] = '\0';
    put(b);
}

/* sqrt(v), v >= 0, by Newton's iteration (no libm on the target). */
static double root(double v) {
    double r = v > 1.0 ? v : 1.0;
    int i;
    if (v <= 0.0) return 0.0;
    for (i = 0; i < 200; i++) r = 0.5 * (r + v / r);
    return r;
}

static uint32_t fbits(float f) {
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static uint64_t dbits(double f) {
    uint64_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* A triangle wave in [0, 1] of period p. */
static double tri(double t, double p) {
    double s = t / p;
    s -= (double)(long)s;
    return s < 0.5 ? 2.0 * s : 2.0 - 2.0 * s;
}

int main(void) {
    static const double start[3] = {0.01171875, -0.0048828125, 0.00390625};
    F(_observer) obs;
    double x[NX], dx[NX], y[NY], th[NTHETA + 1], floor, worst2 = 0.0;
    float x0[NX], yf[NY], thf[NTHETA + 1];
    uint64_t hash = UINT64_C(14695981039346656037);
    long k;
    int i, ok = 1;
#ifdef SAMPLED
    const float h = F(_SAMPLE_PERIOD);
    floor = (double)F(_F32_STEP_FLOOR);
    put("step: <m>_step at SAMPLE_PERIOD ");
#else
    const float h = H;
    floor = (double)F(_F32_EULER_FLOOR) + (double)F(_F32_EULER_UPDATE_ROUNDING) / (double)h;
    if (!((double)h > (double)F(_F32_EULER_MIN_STEP) && h <= F(_MAX_STEP_EULER))) {
        put("h is outside (F32_EULER_MIN_STEP, MAX_STEP_EULER]: no certified floor");
        end_line();
        return 2;
    }
    put("step: <m>_step_euler at h = ");
#endif
    put_sci((double)h);
    end_line();
    put("certified f32 floor ");
    put_sci(floor);
    end_line();
    if (!(floor < 1e30)) {
        put("no certified floor");
        end_line();
        return 2;
    }
    for (i = 0; i < NX; i++) {
        x[i] = start[i % 3] * X0_SCALE;
        x0[i] = (float)x[i];
        x[i] = (double)x0[i]; /* the observer starts at exactly x(0) */
    }
    F(_init_at)(&obs, x0);
    for (k = 0; k < STEPS; k++) {
        const double t = (double)k * (double)h;
        const float *xh;
        double e2 = 0.0;
        for (i = 0; i < NTHETA; i++) {
            const double lo = (double)F(_THETA_MIN)[i], hi = (double)F(_THETA_MAX)[i];
            th[i] = lo + (hi - lo) * tri(t, 0.9 + 0.37 * i);
            thf[i] = (float)th[i];
        }
        D(_plant_output)(x, th, y);
        for (i = 0; i < NY; i++) yf[i] = (float)y[i];
#ifdef SAMPLED
        F(_step)(&obs, yf, NULL, thf);
#else
        F(_step_euler)(&obs, h, yf, NULL, thf);
#endif
        D(_plant_derivative)(x, NULL, th, dx);
        for (i = 0; i < NX; i++) x[i] = x[i] + (double)h * dx[i];
        xh = F(_estimate)(&obs);
        for (i = 0; i < NX; i++) {
            const double e = x[i] - (double)xh[i];
            uint32_t b = fbits(xh[i]);
            int j;
            e2 += e * e;
            for (j = 0; j < 4; j++) {
                hash ^= (b >> (8 * j)) & 0xffu;
                hash *= UINT64_C(1099511628211);
            }
        }
        if (e2 > worst2) worst2 = e2;
        if (e2 > floor * floor) ok = 0;
        if ((k + 1) % 500 == 0) {
            put("step ");
            put_hex((uint64_t)(k + 1), 4);
            for (i = 0; i < NX; i++) {
                put(" ");
                put_hex(fbits(xh[i]), 8);
            }
            end_line();
        }
    }
    put("estimate hash ");
    put_hex(hash, 16);
    end_line();
    put("largest |x - xhat|^2 bits ");
    put_hex(dbits(worst2), 16);
    end_line();
    put(ok ? "PASS" : "FAIL");
    put(": largest |x - xhat| = ");
    put_sci(root(worst2));
    put(" against the certified floor ");
    put_sci(floor);
    end_line();
    return ok ? 0 : 1;
}
