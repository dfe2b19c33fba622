/* One lens's folded SH projection of an 8-bit frame, decoded through its table in the same
 * pass (issue 34), and the lights' block means of the same decoded pixels.
 *
 * The lens is radially symmetric about its centre, so the four pixels mirrored about it
 * carry the same lens-frame weights up to a sign per axis (provider/core/sh9/lens_fold.py):
 *
 *   sums[k][c] += sum over quarter pixels q of tables[k][q] * fold_{parity[k]}(q, c)
 *
 * where, for q = (i, j) (row i below the centre, column j right of it), a, b the bottom
 * row's right and left pixels and c, d the top row's (channel c, decoded), the folds are
 *   parity 0 (x even, y even): (a + b) + (c + d)    parity 1 (x odd, y even): (a - b) + (c - d)
 *   parity 2 (x even, y odd):  (a + b) - (c + d)    parity 3 (x odd, y odd):  (a - b) - (c - d)
 *
 * fold_lens(frame, table, geometry, extents, radial, inv_step, fix_at, fixes, tables,
 *           parities, sums, mid, factor, clear[, clip[, residual[, first]]]) -> None or total
 * (its Python twin, the same signature, numbers and errors: fold_twin.py)
 *   frame     uint8 (H, W, 3), pixels contiguous (rows may be strided); or, without a
 *             table, linear float32 (H, W, 3) (the fast path's block means, a float frame)
 *   table     float32, 256 entries (one curve) or 768 (per channel, entry v*3 + c); or None
 *   geometry  (xl, xr, yt, yb, nx, ny): quarter pixel (i, j) reads columns xr + j, xl - 1 - j
 *             and rows yb + i, yt - 1 - i, for i < ny, j < nx
 *   others    int32 (M, 2): the (xl, xr) of M more lenses with the same rows and weights
 *             (xr - xl the same: the two lenses of a dual fisheye), each summed into its own
 *             sums: one lens's weight rows made once a row pair for all (M = 0: one lens)
 *   extents   int32 (ny,): row pair i reads columns j < extents[i] only (beyond, every
 *             weight is zero and no block of mid is seen)
 *   radial    float32 (B, 20): the lens-frame SH9 weights as functions of the distance r of
 *             the quarter pixel's centre from the lens centre (dx = j + (xr - xl + 1) / 2,
 *             dy = i + (yb - yt + 1) / 2, r = sqrt(dx^2 + dy^2)), linear in each bin b =
 *             floor(r * inv_step) (the last bin beyond): columns 0-7 the values of weights
 *             0-7 at the bin's inner edge, 8-15 their slopes (a bin's change), 16 and 17
 *             weight 8's; weight k is (value + (r * inv_step - b) * slope) times its
 *             monomial: 1, dy, 1, dx, dx dy, dy, 1, dx, dx^2 - dy^2 (a radially symmetric
 *             lens: issue 44), and meets the fold 0, 2, 0, 1, 3, 2, 0, 1, 0
 *   inv_step  1 / the bins' width in pixels (> 0)
 *   fix_at    int32 (F,), increasing quarter pixel indices i * nx + j, and
 *   fixes     float32 (F, 9): added to those pixels' SH9 weights (where the radial form does
 *             not hold to the build's tolerance: the circle's edge, a blend's seam)
 *   tables    float32 (K, ny * nx), row k the quarter table of extra weight k (K may be 0)
 *   parities  int32 (K,): the fold each extra weight meets (0..3 above)
 *   sums      float64 (1 + M, 9 + K, 3), added to, a lens each: the SH9 weights' sums,
 *             then the extras'
 *   mid       None, or float32 (H / f, W / f, 3): the sums of the decoded pixels over f x f
 *             blocks are added to it (the caller divides by f * f once every pixel is in:
 *             the lights' block copy, black where nothing was read)
 *   factor    f >= 1 (ignored without mid)
 *   clear     true: mid is zeroed first (the first lens's call; a row at a time as its
 *             first sums come, the rows no lens reaches at the end: the same numbers)
 *   clip      None, or float64 (4,) added to (8-bit frames only): clip[0] the samples at
 *             code 255 in the lenses' squares (every column j < nx, whatever the extents:
 *             the clip counter's clipped_fraction counts the whole frame), clip[1 + c] the
 *             L00 weight (weight 0, the same in the lens frame and the world's) of the
 *             pixels whose channel c is at 255, over the pixels read (j < extents[i]) and
 *             the residual pixels
 *   residual  None, or (starts, cols, weights, rsums): the pixels no fold pairs (a lens's
 *             centre row and column, a frame's edge), each read while its row is in cache
 *             (the rows no row pair reads first): starts int32 (H + 1,) from 0,
 *             non-decreasing, to R (row y's pixels are starts[y] .. starts[y + 1]), cols
 *             int32 (R,) their columns, weights float32 (R, C) their world-frame weights,
 *             rsums float64 (C, 3) added to: sum of weight times decoded sample; their L00
 *             (column 0) where clipped into clip, their samples into mid's blocks
 *   first     None, or (luma, omega, Y, coarse, cf, scale, Ymax): the lights' first pass
 *             (lights/_lights.c's first_pass, first_pass_band.h) run on each band of cf
 *             rows of mid once every lens has spilled into it, while it is in cache (the
 *             rest at the end); needs mid and clear (the only call); returns its sum of
 *             Y omega
 *
 * Per row pair: the four half rows decoded into planar float rows (a byte load and a table
 * load a sample: the only scalar loop), then plain loops over j that the compiler
 * runs four floats at a time (GCC's vector extension: SSE, NEON; elsewhere scalar loops,
 * buffer_check.h's KERNEL_VECTOR): the four folds with each
 * half row added to its column sums over the rows of its block row (spilled into mid by
 * blocks when the block row changes), and the dot products of up to three weights with
 * their fold's three channels, added to float64 sums once a row. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdlib.h>
#include <string.h>

#include "buffer_check.h"
#include "first_pass_band.h"

#include <math.h>
#if KERNEL_VECTOR && defined(__SSE__)
#include <xmmintrin.h>
#elif KERNEL_VECTOR && defined(__ARM_NEON) && defined(__aarch64__)
#include <arm_neon.h>
#endif

#define NVIEWS 21

#if KERNEL_VECTOR
/* Four floats: GCC's and Clang's vector extension, SSE on x86-64 and NEON on 64-bit ARM.
 * Without it (MSVC) every loop below runs its scalar tail over the whole row. */
typedef float v4 __attribute__((vector_size(16)));

static inline v4
load4(const float *p)
{
    v4 v;
    memcpy(&v, p, sizeof v);
    return v;
}

static inline void
store4(float *p, v4 v)
{
    memcpy(p, &v, sizeof v);
}
#endif

/* A half row of n pixels decoded into three planar rows; step = +3 (rightwards from p) or
 * -3 (leftwards: p is the pixel next to the centre). */
static inline void
decode_half(const unsigned char *restrict p, Py_ssize_t step, Py_ssize_t n,
            const float *restrict t, int shared, float *restrict r, float *restrict g,
            float *restrict b)
{
    Py_ssize_t j = 0;
    if (shared) {
        for (; j + 2 <= n; j += 2, p += 2 * step) {   /* two pixels a turn: less loop */
            const float r0 = t[p[0]], g0 = t[p[1]], b0 = t[p[2]];
            const float r1 = t[p[step]], g1 = t[p[step + 1]], b1 = t[p[step + 2]];
            r[j] = r0; g[j] = g0; b[j] = b0;
            r[j + 1] = r1; g[j + 1] = g1; b[j + 1] = b1;
        }
        for (; j < n; j++, p += step) {
            r[j] = t[p[0]];
            g[j] = t[p[1]];
            b[j] = t[p[2]];
        }
    } else {
        for (; j < n; j++, p += step) {
            r[j] = t[p[0] * 3];
            g[j] = t[p[1] * 3 + 1];
            b[j] = t[p[2] * 3 + 2];
        }
    }
}

/* A half row of n linear float32 pixels split into three planar rows (step as above). */
static inline void
split_half(const float *restrict p, Py_ssize_t step, Py_ssize_t n, float *restrict r,
           float *restrict g, float *restrict b)
{
    for (Py_ssize_t j = 0; j < n; j++, p += step) {
        r[j] = p[0];
        g[j] = p[1];
        b[j] = p[2];
    }
}

/* Whether any of n bytes is 255: 64 bytes a turn (16-byte compares where vectors are at
 * hand), then 16. */
static inline int
any_top(const unsigned char *restrict p, Py_ssize_t n)
{
    Py_ssize_t i = 0;
#if KERNEL_VECTOR
    typedef unsigned char u16 __attribute__((vector_size(16)));
    u16 hit = {0};
    for (; i + 64 <= n; i += 64) {
        u16 v0, v1, v2, v3;
        memcpy(&v0, p + i, 16);
        memcpy(&v1, p + i + 16, 16);
        memcpy(&v2, p + i + 32, 16);
        memcpy(&v3, p + i + 48, 16);
        /* (hit = hit | ..., not |=: GCC compiles the latter as a select) */
        hit = hit | (u16)((v0 == 255) | (v1 == 255) | (v2 == 255) | (v3 == 255));
    }
    for (; i + 16 <= n; i += 16) {
        u16 v;
        memcpy(&v, p + i, 16);
        hit = hit | (u16)(v == 255);
    }
    if (i < n && n >= 16) {     /* the last 16 bytes, overlapping: no scalar tail */
        u16 v;
        memcpy(&v, p + n - 16, 16);
        hit = hit | (u16)(v == 255);
        i = n;
    }
    long long lanes[2];
    memcpy(lanes, &hit, sizeof lanes);
    if (lanes[0] | lanes[1])
        return 1;
#endif
    for (; i < n; i++)
        if (p[i] == 255)
            return 1;
    return 0;
}

/* The bytes at 255 among n: 16 a turn in byte counters (a compare's -1 subtracted),
 * emptied every 255 turns, before they wrap. */
static Py_ssize_t
count_255(const unsigned char *restrict p, Py_ssize_t n)
{
    Py_ssize_t i = 0, total = 0;
#if KERNEL_VECTOR
    typedef unsigned char u16 __attribute__((vector_size(16)));
    while (i + 16 <= n) {
        u16 c = {0};
        for (int turn = 0; turn < 255 && i + 16 <= n; turn++, i += 16) {
            u16 v;
            memcpy(&v, p + i, 16);
            c = c - (u16)(v == 255);
        }
        for (int l = 0; l < 16; l++)
            total += c[l];
    }
#endif
    for (; i < n; i++)
        total += p[i] == 255;
    return total;
}

/* The clip counter's share of a half row of n pixels (p and step as decode_half's): its
 * samples at code 255 added to *count, and the weight w[j] of each one's pixel, for the
 * first e pixels (the others weigh nothing), to its channel's l00[c]. The half row's bytes
 * are checked at once, then, where one clips, 16 pixels at a time: a frame with no clipped
 * sample costs a compare per 16 bytes, a lamp a few scalar turns. */
static void
clip_half(const unsigned char *restrict p, Py_ssize_t step, Py_ssize_t n, Py_ssize_t e,
          const float *restrict w, Py_ssize_t *restrict count, double *restrict l00)
{
    if (!any_top(step > 0 ? p : p - 3 * (n - 1), 3 * n))
        return;
    for (Py_ssize_t j0 = 0; j0 < n; j0 += 16) {
        const Py_ssize_t j1 = j0 + 16 < n ? j0 + 16 : n;
        if (!any_top(step > 0 ? p + 3 * j0 : p - 3 * (j1 - 1), 3 * (j1 - j0)))
            continue;
        for (Py_ssize_t j = j0; j < j1; j++) {
            const unsigned char *q = p + step * j;
            for (int c = 0; c < 3; c++)
                if (q[c] == 255) {
                    (*count)++;
                    if (j < e)
                        l00[c] += w[j];
                }
        }
    }
}

/* n floats set to 0 with vector stores: for long runs glibc's memset uses "rep stosb",
 * which callgrind (the edge bench's counter) counts a byte at a time. */
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("no-tree-loop-distribute-patterns")))   /* not back into memset */
#endif
static void
zero(float *p, Py_ssize_t n)
{
    Py_ssize_t j = 0;
#if KERNEL_VECTOR
    const v4 z = {0, 0, 0, 0};
    for (; j + 4 <= n; j += 4)
        store4(p + j, z);
#endif
    for (; j < n; j++)
        p[j] = 0.0f;
}

/* Column sums (3 planar rows of n, stride apart) of one half row's block row into mid's
 * row of blocks: column x0 + j (dir +1) or x0 - j (dir -1) is in block x / f; then the sums
 * are zeroed. Runs once every f rows. */
static void
spill(float *restrict col, Py_ssize_t stride, Py_ssize_t n, Py_ssize_t x0, int dir, int f,
      float *restrict mrow)
{
    Py_ssize_t blk = x0 / f, run = dir > 0 ? f - x0 % f : x0 % f + 1, j = 0;
    for (; j < n; j += run, run = f, blk += dir) {
        if (run > n - j)
            run = n - j;
        if (run == 4) {         /* whole blocks of the usual factor, written out */
            for (int c = 0; c < 3; c++) {
                const float *x = col + c * stride + j;
                mrow[blk * 3 + c] += (x[0] + x[1]) + (x[2] + x[3]);
            }
            continue;
        }
        for (int c = 0; c < 3; c++) {
            float s = 0.0f;
            for (Py_ssize_t l = j; l < j + run; l++)
                s += col[c * stride + l];
            mrow[blk * 3 + c] += s;
        }
    }
    for (int c = 0; c < 3; c++)       /* short: memset's vector stores */
        memset(col + c * stride, 0, sizeof(float) * (size_t)n);
}

/* The four folds of one channel's quarter row (bottom right a, bottom left b, top right c,
 * top left d). */
static inline void
fold_row(const float *restrict a, const float *restrict b, const float *restrict c,
         const float *restrict d, float *restrict ee, float *restrict oe, float *restrict eo,
         float *restrict oo, Py_ssize_t n)
{
    Py_ssize_t j = 0;
#if KERNEL_VECTOR
    for (; j + 4 <= n; j += 4) {
        const v4 va = load4(a + j), vb = load4(b + j), vc = load4(c + j), vd = load4(d + j);
        const v4 s1 = va + vb, d1 = va - vb, s2 = vc + vd, d2 = vc - vd;
        store4(ee + j, s1 + s2);
        store4(oe + j, d1 + d2);
        store4(eo + j, s1 - s2);
        store4(oo + j, d1 - d2);
    }
#endif
    for (; j < n; j++) {
        const float s1 = a[j] + b[j], d1 = a[j] - b[j];
        const float s2 = c[j] + d[j], d2 = c[j] - d[j];
        ee[j] = s1 + s2;
        oe[j] = d1 + d2;
        eo[j] = s1 - s2;
        oo[j] = d1 - d2;
    }
}

/* fold_row, and each of the four half rows added to its column sums (ca .. cd). */
static inline void
fold_row_sums(const float *restrict a, const float *restrict b, const float *restrict c,
              const float *restrict d, float *restrict ee, float *restrict oe,
              float *restrict eo, float *restrict oo, float *restrict ca, float *restrict cb,
              float *restrict cc, float *restrict cd, Py_ssize_t n)
{
    Py_ssize_t j = 0;
#if KERNEL_VECTOR
    for (; j + 4 <= n; j += 4) {
        const v4 va = load4(a + j), vb = load4(b + j), vc = load4(c + j), vd = load4(d + j);
        const v4 s1 = va + vb, d1 = va - vb, s2 = vc + vd, d2 = vc - vd;
        store4(ee + j, s1 + s2);
        store4(oe + j, d1 + d2);
        store4(eo + j, s1 - s2);
        store4(oo + j, d1 - d2);
        store4(ca + j, load4(ca + j) + va);
        store4(cb + j, load4(cb + j) + vb);
        store4(cc + j, load4(cc + j) + vc);
        store4(cd + j, load4(cd + j) + vd);
    }
#endif
    fold_row(a + j, b + j, c + j, d + j, ee + j, oe + j, eo + j, oo + j, n - j);
    for (; j < n; j++) {
        ca[j] += a[j];
        cb[j] += b[j];
        cc[j] += c[j];
        cd[j] += d[j];
    }
}

/* For m (1 to 3) weight rows w[0..m) that meet the same fold (x0, x1, x2: its three
 * channels): out[r][c] += sum_j w[r][j] * x_c[j], in four float lanes per sum. Inlined with
 * m constant: the fold is loaded once for the m rows, the 3m sums stay in registers. */
KERNEL_INLINE void
dots(const float *const *w, int m, const float *restrict x0, const float *restrict x1,
     const float *restrict x2, Py_ssize_t n, double *const *out)
{
#if KERNEL_VECTOR
    v4 acc[3][3];
    for (int r = 0; r < m; r++)
        for (int c = 0; c < 3; c++)
            acc[r][c] = (v4){0, 0, 0, 0};
    Py_ssize_t j = 0;
    for (; j + 4 <= n; j += 4) {
        const v4 a = load4(x0 + j), b = load4(x1 + j), c = load4(x2 + j);
        for (int r = 0; r < m; r++) {
            const v4 wv = load4(w[r] + j);
            acc[r][0] += wv * a;
            acc[r][1] += wv * b;
            acc[r][2] += wv * c;
        }
    }
#else
    const Py_ssize_t j = 0;
#endif
    for (int r = 0; r < m; r++) {
        float s[3];
        for (int c = 0; c < 3; c++)
#if KERNEL_VECTOR
            s[c] = (acc[r][c][0] + acc[r][c][1]) + (acc[r][c][2] + acc[r][c][3]);
#else
            s[c] = 0.0f;
#endif
        for (Py_ssize_t l = j; l < n; l++) {
            s[0] += w[r][l] * x0[l];
            s[1] += w[r][l] * x1[l];
            s[2] += w[r][l] * x2[l];
        }
        for (int c = 0; c < 3; c++)
            out[r][c] += s[c];
    }
}

/* The fold code of each SH9 weight and the order the dots take them in (grouped by fold). */
static const int SH_PARITY[9] = {0, 2, 0, 1, 3, 2, 0, 1, 0};
static const int SH_ORDER[9] = {0, 2, 6, 8, 3, 7, 1, 5, 4};

#if KERNEL_VECTOR
typedef int v4i __attribute__((vector_size(16)));
#if defined(__clang__)
#define SHUF(a, b, i, j, k, l) __builtin_shufflevector(a, b, i, j, k, l)
#else
#define SHUF(a, b, i, j, k, l) __builtin_shuffle(a, b, (v4i){i, j, k, l})
#endif

/* Four square roots: one instruction where the target has it (IEEE's, as sqrtf's). */
static inline v4
sqrt4(v4 x)
{
#if defined(__SSE__)
    return (v4)_mm_sqrt_ps((__m128)x);
#elif defined(__ARM_NEON) && defined(__aarch64__)
    return (v4)vsqrtq_f32((float32x4_t)x);
#else
    for (int p = 0; p < 4; p++)
        x[p] = sqrtf(x[p]);
    return x;
#endif
}

/* The four pixels' vectors a..d (lane k: weight k) as four rows of weights (lane p: pixel
 * p), in place. */
static inline void
transpose4(v4 *a, v4 *b, v4 *c, v4 *d)
{
    const v4 t0 = SHUF(*a, *b, 0, 4, 1, 5), t1 = SHUF(*a, *b, 2, 6, 3, 7);
    const v4 t2 = SHUF(*c, *d, 0, 4, 1, 5), t3 = SHUF(*c, *d, 2, 6, 3, 7);
    *a = SHUF(t0, t2, 0, 1, 4, 5);
    *b = SHUF(t0, t2, 2, 3, 6, 7);
    *c = SHUF(t1, t3, 0, 1, 4, 5);
    *d = SHUF(t1, t3, 2, 3, 6, 7);
}
#endif

/* The nine SH9 weight rows (w + k * stride, j < n) of row pair i (dy) from the radial table
 * (nb bins of 20 floats): per pixel its bin's two rows of values and slopes, then per four
 * pixels a transpose and the monomials. */
static void
radial_row(const float *restrict rad, Py_ssize_t nb, float inv, float dx0, float dy,
           Py_ssize_t n, float *restrict w, Py_ssize_t stride)
{
    const float dy2 = dy * dy;
    Py_ssize_t j = 0;
#if KERNEL_VECTOR
    const v4 dyv = {dy, dy, dy, dy}, dy2v = {dy2, dy2, dy2, dy2}, invv = {inv, inv, inv, inv};
    const v4 four = {4, 4, 4, 4};
    v4 x = {dx0, dx0 + 1, dx0 + 2, dx0 + 3};
    const v4i last_bin = {(int)nb - 1, (int)nb - 1, (int)nb - 1, (int)nb - 1};
    for (; j + 4 <= n; j += 4, x += four) {
        /* the four pixels' bins (at most the last) and fractions, in vector registers */
        const v4 t = sqrt4(x * x + dy2v) * invv;
        v4i bin = __builtin_convertvector(t, v4i);
        const v4i over = bin > last_bin;
        bin = (bin & ~over) | (last_bin & over);
        int bins[4];
        float frac[4], last[4];
        memcpy(bins, &bin, sizeof bins);
        store4(frac, t - __builtin_convertvector(bin, v4));
        v4 lo[4], hi[4];
        for (int p = 0; p < 4; p++) {
            const float *row = rad + 20 * (Py_ssize_t)bins[p];
            const float f = frac[p];
            const v4 fv = {f, f, f, f};
            lo[p] = load4(row) + fv * load4(row + 8);
            hi[p] = load4(row + 4) + fv * load4(row + 12);
            last[p] = row[16] + f * row[17];
        }
        transpose4(&lo[0], &lo[1], &lo[2], &lo[3]);
        transpose4(&hi[0], &hi[1], &hi[2], &hi[3]);
        store4(w + j, lo[0]);
        store4(w + stride + j, lo[1] * dyv);
        store4(w + 2 * stride + j, lo[2]);
        store4(w + 3 * stride + j, lo[3] * x);
        store4(w + 4 * stride + j, hi[0] * (x * dyv));
        store4(w + 5 * stride + j, hi[1] * dyv);
        store4(w + 6 * stride + j, hi[2]);
        store4(w + 7 * stride + j, hi[3] * x);
        store4(w + 8 * stride + j, load4(last) * (x * x - dy2v));
    }
#endif
    for (; j < n; j++) {
        const float x = dx0 + (float)j;
        const float t = sqrtf(x * x + dy2) * inv;
        Py_ssize_t b = (Py_ssize_t)t;
        if (b > nb - 1)
            b = nb - 1;
        const float f = t - (float)b;
        const float *row = rad + 20 * b;
        const float m[9] = {1, dy, 1, x, x * dy, dy, 1, x, x * x - dy2};
        for (int k = 0; k < 8; k++)
            w[k * stride + j] = (row[k] + f * row[8 + k]) * m[k];
        w[8 * stride + j] = (row[16] + f * row[17]) * m[8];
    }
}

static PyObject *
fold_lens(PyObject *self, PyObject *args)
{
    PyObject *frame_obj, *table_obj, *ext_obj, *tab_obj, *par_obj, *sums_obj, *mid_obj;
    PyObject *rad_obj, *fat_obj, *fix_obj, *oth_obj, *clip_obj = Py_None;
    PyObject *res_obj = Py_None, *first_obj = Py_None;
    Py_ssize_t xl, xr, yt, yb, nx, ny;
    double inv_step;
    int f, clear;
    if (!PyArg_ParseTuple(args, "OO(nnnnnn)OOOdOOOOOOip|OOO", &frame_obj, &table_obj, &xl,
                          &xr, &yt, &yb, &nx, &ny, &oth_obj, &ext_obj, &rad_obj, &inv_step,
                          &fat_obj, &fix_obj, &tab_obj, &par_obj, &sums_obj, &mid_obj, &f,
                          &clear, &clip_obj, &res_obj, &first_obj))
        return NULL;
    const int use_res = res_obj != Py_None, use_first = first_obj != Py_None;
    if (use_res && !(PyTuple_Check(res_obj) && PyTuple_GET_SIZE(res_obj) == 4)) {
        PyErr_SetString(PyExc_TypeError,
                        "residual: a tuple (starts, cols, weights, sums) or None");
        return NULL;
    }
    if (use_first && !(PyTuple_Check(first_obj) && PyTuple_GET_SIZE(first_obj) == 7)) {
        PyErr_SetString(PyExc_TypeError,
                        "first: a tuple (luma, omega, Y, coarse, factor, scale, Ymax) or None");
        return NULL;
    }
    Py_ssize_t cf = 1;
    double fscale = 1.0;
    if (use_first) {
        cf = PyLong_AsSsize_t(PyTuple_GET_ITEM(first_obj, 4));
        if (cf == -1 && PyErr_Occurred())
            return NULL;
        fscale = PyFloat_AsDouble(PyTuple_GET_ITEM(first_obj, 5));
        if (fscale == -1.0 && PyErr_Occurred())
            return NULL;
    }
    PyObject *coarse_obj = use_first ? PyTuple_GET_ITEM(first_obj, 3) : Py_None;
    Py_buffer views[NVIEWS];
    memset(views, 0, sizeof views);
    int got[NVIEWS] = {0};
    int use_mid = mid_obj != Py_None, linear = table_obj == Py_None;
    const int use_clip = clip_obj != Py_None;
    const char *err = NULL;
    double total_out = 0.0;             /* the first pass's sum of Y omega (first) */
#define VIEW(n, obj, w, fmt, nd, name) \
    do { if (get_view(obj, &views[n], w, fmt, nd, name) < 0) goto fail; got[n] = 1; } while (0)
    VIEW(0, frame_obj, 0, linear ? "f" : "B", 3, linear ? "frame (no table: float32)"
                                                       : "frame (with a table: uint8)");
    if (!linear)
        VIEW(1, table_obj, 0, "f", 1, "table");
    VIEW(10, oth_obj, 0, "i", 2, "others");
    VIEW(2, ext_obj, 0, "i", 1, "extents");
    VIEW(7, rad_obj, 0, "f", 2, "radial");
    VIEW(8, fat_obj, 0, "i", 1, "fix_at");
    VIEW(9, fix_obj, 0, "f", 2, "fixes");
    VIEW(3, tab_obj, 0, "f", 2, "tables");
    VIEW(4, par_obj, 0, "i", 1, "parities");
    VIEW(5, sums_obj, 1, "d", 3, "sums");
    if (use_mid)
        VIEW(6, mid_obj, 1, "f", 3, "mid");
    if (use_clip)
        VIEW(11, clip_obj, 1, "d", 1, "clip");
    if (use_res) {
        VIEW(12, PyTuple_GET_ITEM(res_obj, 0), 0, "i", 1, "residual starts");
        VIEW(13, PyTuple_GET_ITEM(res_obj, 1), 0, "i", 1, "residual cols");
        VIEW(14, PyTuple_GET_ITEM(res_obj, 2), 0, "f", 2, "residual weights");
        VIEW(15, PyTuple_GET_ITEM(res_obj, 3), 1, "d", 2, "residual sums");
    }
    if (use_first) {
        VIEW(16, PyTuple_GET_ITEM(first_obj, 0), 0, "f", 1, "luma");
        VIEW(17, PyTuple_GET_ITEM(first_obj, 1), 0, "f", 2, "omega");
        VIEW(18, PyTuple_GET_ITEM(first_obj, 2), 1, "f", 2, "Y");
        VIEW(20, PyTuple_GET_ITEM(first_obj, 6), 1, "f", 1, "Ymax");
        if (coarse_obj != Py_None)
            VIEW(19, coarse_obj, 1, "f", 3, "coarse");
    }
#undef VIEW
    Py_buffer fr = views[0], tb = views[1], ex = views[2], tabs = views[3], par = views[4];
    Py_buffer sums = views[5], mid = views[6], rad = views[7], fat = views[8], fix = views[9];
    Py_buffer oth = views[10], cl = views[11];
    Py_buffer rst = views[12], rcol = views[13], rw = views[14], rsum = views[15];
    Py_buffer lu = views[16], om = views[17], yv = views[18], co = views[19], ym = views[20];
    const int use_coarse = use_first && coarse_obj != Py_None;
    const Py_ssize_t L = 1 + oth.shape[0];
    Py_ssize_t H = fr.shape[0], W = fr.shape[1], K = tabs.shape[0];
    const Py_ssize_t item = linear ? 4 : 1;
    if (fr.shape[2] != 3 || fr.strides[2] != item || fr.strides[1] != 3 * item)
        err = "frame: (H, W, 3) with contiguous pixels";
    else if (!linear && (!contiguous(&tb) || (tb.shape[0] != 256 && tb.shape[0] != 768)))
        err = "table: 256 contiguous entries, or 768 (per channel)";
    /* xl <= xr, yt <= yb and the square's outer edges inside the frame bound every row and
     * column read (written as differences: no overflow whatever the arguments). */
    else if (nx < 1 || ny < 1 || xl < nx || yt < ny || xr < xl || yb < yt || nx > W - xr
             || ny > H - yb)
        err = "geometry: the square must lie inside the frame";
    else if (!contiguous(&oth) || oth.shape[1] != 2)
        err = "others: (M, 2) contiguous int32";
    else if (!contiguous(&ex) || ex.shape[0] != ny)
        err = "extents: (ny,) contiguous int32";
    else if (!contiguous(&rad) || rad.shape[0] < 1 || rad.shape[1] != 20)
        err = "radial: (B, 20) contiguous float32";
    else if (!(inv_step > 0.0 && inv_step < HUGE_VAL))
        err = "inv_step: positive and finite";
    else if (!contiguous(&fat) || !contiguous(&fix) || fix.shape[0] != fat.shape[0]
             || fix.shape[1] != 9)
        err = "fixes: (F,) int32 and (F, 9) float32, contiguous";
    else if (!contiguous(&tabs) || tabs.shape[1] != nx * ny)
        err = "tables: (K, ny * nx) contiguous float32";
    else if (!contiguous(&par) || par.shape[0] != K)
        err = "parities: (K,) contiguous int32";
    else if (!contiguous(&sums) || sums.shape[0] != L || sums.shape[1] != 9 + K
             || sums.shape[2] != 3)
        err = "sums: (1 + M, 9 + K, 3) contiguous float64";
    else if (use_mid && (f < 1 || !contiguous(&mid) || mid.shape[0] != H / f
                         || mid.shape[1] != W / f || mid.shape[2] != 3
                         || nx > (W / f) * f - xr || ny > (H / f) * f - yb))
        err = "mid: (H / f, W / f, 3) float32 holding the square's blocks";
    else if (use_clip && (linear || !contiguous(&cl) || cl.shape[0] != 4))
        err = "clip: (4,) contiguous float64, with a table (an 8-bit frame)";
    else if (use_res && (!contiguous(&rst) || !contiguous(&rcol) || !contiguous(&rw)
                         || !contiguous(&rsum) || rst.shape[0] != H + 1
                         || rw.shape[0] != rcol.shape[0] || rw.shape[1] < 1
                         || rsum.shape[0] != rw.shape[1] || rsum.shape[1] != 3))
        err = "residual: starts (H + 1,) int32, cols (R,) int32, weights (R, C) float32, "
              "sums (C, 3) float64, contiguous";
    else if (use_first && (!use_mid || !clear))
        err = "first: with mid, in the call that clears it (the only call)";
    else if (use_first && (!contiguous(&lu) || lu.shape[0] != 3))
        err = "luma: (3,) float32";
    else if (use_first && (!contiguous(&om) || !contiguous(&yv) || om.shape[0] != H / f
                           || om.shape[1] != W / f || yv.shape[0] != H / f
                           || yv.shape[1] != W / f))
        err = "omega, Y: (h, w) float32, mid's height and width";
    else if (use_first && (!contiguous(&ym) || ym.shape[0] != H / f))
        err = "Ymax: (h,) float32";
    else if (use_first && cf < 1)
        err = "first: factor at least 1";
    else if (use_coarse && (!contiguous(&co) || co.shape[2] != 3
                            || co.shape[0] > (H / f) / cf || co.shape[1] > (W / f) / cf))
        err = "coarse: (hc, wc, 3) float32, hc * factor <= h, wc * factor <= w";
    /* The residual pixels' rows: starts from 0, non-decreasing, to R; columns in the frame. */
    const int *rs = err || !use_res ? NULL : (const int *)rst.buf;
    const int *rc = err || !use_res ? NULL : (const int *)rcol.buf;
    if (rs != NULL) {
        if (rs[0] != 0 || rs[H] != rcol.shape[0])
            err = "residual: starts from 0 to R, non-decreasing";
        for (Py_ssize_t y = 0; !err && y < H; y++)
            if (rs[y + 1] < rs[y])
                err = "residual: starts from 0 to R, non-decreasing";
        for (Py_ssize_t q = 0; !err && q < rcol.shape[0]; q++)
            if (rc[q] < 0 || rc[q] >= W)
                err = "residual: cols in [0, W)";
    }
    /* The other lenses: their columns as the first's (the same centre offset: the same
     * weights), inside the frame and mid's blocks. */
    const int *others = err ? NULL : (const int *)oth.buf;
    for (Py_ssize_t l = 0; !err && l + 1 < L; l++) {
        const Py_ssize_t ol = others[2 * l], orr = others[2 * l + 1];
        if (ol < nx || orr - ol != xr - xl || nx > W - orr
            || (use_mid && nx > (W / f) * f - orr))
            err = "others: (xl, xr) of lenses like the first, inside the frame";
    }
    const int *extent = (const int *)ex.buf;
    const int *parity = (const int *)par.buf;
    for (Py_ssize_t i = 0; !err && i < ny; i++)
        if (extent[i] < 0 || extent[i] > nx)
            err = "extents: in [0, nx]";
    for (Py_ssize_t k = 0; !err && k < K; k++)
        if (parity[k] < 0 || parity[k] > 3)
            err = "parities: 0 to 3";
    const int *at = (const int *)fat.buf;
    const Py_ssize_t F = fat.shape[0];
    for (Py_ssize_t q = 0; !err && q < F; q++)
        if (at[q] < 0 || at[q] >= nx * ny || (q > 0 && at[q] <= at[q - 1]))
            err = "fixes: increasing indices in [0, ny * nx)";
    if (err) {
        PyErr_SetString(PyExc_ValueError, err);
        goto fail;
    }
    /* Planar rows: 4 half rows x 3 channels decoded, 4 folds x 3 channels, per half row
     * and channel the block sums of a block row (mid), and the 9 SH9 weight rows. */
    float *buf = (float *)malloc(sizeof(float) * (size_t)((33 + 12 * L) * nx));
    Py_ssize_t *spills = (Py_ssize_t *)malloc(sizeof(Py_ssize_t) * (size_t)(12 * L));
    if (buf == NULL || spills == NULL) {
        free(buf);
        free(spills);
        PyErr_NoMemory();
        goto fail;
    }
    {
        float *half = buf;                  /* [h][c][j], h: 0 bottom right, 1 bottom left,
                                               2 top right, 3 top left */
        float *folds = buf + 12 * nx;       /* [parity][c][j] */
        float *wrows = folds + 12 * nx;     /* [k][j]: the SH9 weights of the row pair */
        float *cols_all = wrows + 9 * nx;   /* [lens][h][c][j]: column sums of a block row */
        const float *radp = (const float *)rad.buf, *fixp = (const float *)fix.buf;
        const Py_ssize_t nb = rad.shape[0];
        const float inv = (float)inv_step;
        const float dx0 = (float)(xr - xl + 1) * 0.5f, dy0 = (float)(yb - yt + 1) * 0.5f;
        Py_ssize_t fq = 0;                  /* the next fix */
        /* The weight rows the dots take, in their order (grouped by fold), and where each
         * one's sums go. */
        const Py_ssize_t KT = 9 + K;
        Py_ssize_t *order = (Py_ssize_t *)malloc(sizeof(Py_ssize_t) * (size_t)KT);
        int *fold_of = (int *)malloc(sizeof(int) * (size_t)KT);
        /* clear: each row of mid is zeroed when its first block sums come (a flag a row),
         * not all of mid before the pass: a Theta's mid copy (675 KB) is past a 512 KB
         * cache by then, so zeroing it first cost its bytes from DRAM twice (cachegrind:
         * 1.2 -> 0.7 MB a frame; issue 44); the rows no lens reaches are zeroed at the end. */
        unsigned char *fresh = use_mid && clear ? (unsigned char *)malloc((size_t)(H / f) + 1)
                                                : NULL;
        /* The residual pixels' sums (C weights x 3 channels, double), and the first pass's
         * bands of cf mid rows (done or not). */
        const Py_ssize_t RC = use_res ? rw.shape[1] : 0;
        const Py_ssize_t mh = use_first ? H / f : 0;
        const Py_ssize_t nbands = use_first ? (mh + cf - 1) / cf : 0;
        double *racc = (double *)calloc((size_t)(3 * RC + 1), sizeof(double));
        unsigned char *bdone = (unsigned char *)calloc((size_t)nbands + 1, 1);
        if (order == NULL || fold_of == NULL || (use_mid && clear && fresh == NULL)
            || racc == NULL || bdone == NULL) {
            free(racc);
            free(bdone);
            free(order);
            free(fold_of);
            free(fresh);
            free(buf);
            free(spills);
            PyErr_NoMemory();
            goto fail;
        }
        if (fresh)
            memset(fresh, 1, (size_t)(H / f) + 1);
        for (Py_ssize_t k = 0; k < KT; k++) {
            order[k] = k < 9 ? SH_ORDER[k] : k;
            fold_of[k] = k < 9 ? SH_PARITY[order[k]] : parity[k - 9];
        }
        const int dir[4] = {1, -1, 1, -1};
        for (Py_ssize_t q = 0; q < 4 * L; q++) {    /* per lens and half row: */
            spills[q] = -1;                         /* its block row, */
            spills[4 * L + q] = 0;                  /* the columns used there, */
        }
        for (Py_ssize_t l = 0; l < L; l++)          /* and its first column */
            for (int h = 0; h < 4; h++) {
                const Py_ssize_t lxl = l ? others[2 * (l - 1)] : xl;
                const Py_ssize_t lxr = l ? others[2 * (l - 1) + 1] : xr;
                spills[8 * L + 4 * l + h] = h % 2 ? lxl - 1 : lxr;
            }
        const float *t = linear ? NULL : (const float *)tb.buf;
        const int shared = linear || tb.shape[0] == 256;
        const float *tab = (const float *)tabs.buf;
        double *out = (double *)sums.buf;
        float *midp = use_mid ? (float *)mid.buf : NULL;
        const Py_ssize_t mw = use_mid ? W / f : 0;
        Py_ssize_t clipped = 0;             /* the clip counter's tally (clip) */
        double clipped_l00[3] = {0.0, 0.0, 0.0};
#define MID_ROW(br) (fresh && fresh[br] ? (zero(midp + (br) * mw * 3, mw * 3), fresh[br] = 0, \
                                           midp + (br) * mw * 3) : midp + (br) * mw * 3)
        /* The residual pixels of frame row y (the pixels no fold pairs: a lens's centre
         * row and column, a frame's edge): decoded, their C world-frame weights' sums, their
         * L00 where clipped, their block sums into mid. Called while the row is in cache. */
#define RESIDUAL_ROW(y) do { \
            const Py_ssize_t yy = (y); \
            const char *row = (const char *)fr.buf + yy * fr.strides[0]; \
            const float *rwp = (const float *)rw.buf; \
            for (Py_ssize_t q = rs[yy]; q < rs[yy + 1]; q++) { \
                const Py_ssize_t x = rc[q]; \
                float px[3]; \
                const unsigned char *code = (const unsigned char *)row + 3 * x; \
                for (int c = 0; c < 3; c++) \
                    px[c] = linear ? ((const float *)row)[3 * x + c] \
                                   : t[shared ? code[c] : 3 * code[c] + c]; \
                const float *wq = rwp + q * RC; \
                for (Py_ssize_t k = 0; k < RC; k++) \
                    for (int c = 0; c < 3; c++) \
                        racc[3 * k + c] += (double)wq[k] * (double)px[c]; \
                if (use_clip) \
                    for (int c = 0; c < 3; c++) \
                        if (code[c] == 255) \
                            clipped_l00[c] += (double)wq[0]; \
                if (use_mid && yy < (H / f) * f && x < mw * f) { \
                    float *mp = MID_ROW(yy / f) + 3 * (x / f); \
                    mp[0] += px[0]; \
                    mp[1] += px[1]; \
                    mp[2] += px[2]; \
                } \
            } \
        } while (0)
        /* The first pass on band b (mid rows b cf .. b cf + cf), its rows zeroed if none
         * was reached. */
#define FIRST_BAND(b) do { \
            for (Py_ssize_t r = (b) * cf; r < (b) * cf + cf && r < mh; r++) \
                (void)MID_ROW(r); \
            first_pass_band(midp, (float *)yv.buf, (float *)ym.buf, (const float *)om.buf, \
                            use_coarse ? (float *)co.buf : NULL, mh, mw, \
                            use_coarse ? co.shape[0] : 0, use_coarse ? co.shape[1] : 0, \
                            cf, (b) * cf, (float)fscale, (const float *)lu.buf, &ftotal); \
            bdone[b] = 1; \
        } while (0)
        double ftotal = 0.0;
        Py_BEGIN_ALLOW_THREADS
        zero(cols_all, 12 * L * nx);    /* only the column sums are read before written */
        /* The residual pixels of the rows no row pair reads, first: afterwards every block
         * sum still to come is a fold's spill (what the first pass's bands wait for). */
        for (Py_ssize_t y = 0; use_res && y < H; y++)
            if (!((y >= yt - ny && y < yt) || (y >= yb && y < yb + ny)))
                RESIDUAL_ROW(y);
        for (Py_ssize_t i = 0; i < ny; i++) {
            const Py_ssize_t e = extent[i];
            if (use_res) {
                RESIDUAL_ROW(yb + i);
                RESIDUAL_ROW(yt - 1 - i);
            }
            if (e > 0)
                radial_row(radp, nb, inv, dx0, dy0 + (float)i, e, wrows, nx);
            /* The pixels of this row pair the radial table does not fit: their corrections
             * (a few hundred a lens, at the circle's edge and a blend's seam). */
            for (; fq < F && at[fq] < (i + 1) * nx; fq++) {
                const Py_ssize_t j = at[fq] - i * nx;
                if (j < e)
                    for (int k = 0; k < 9; k++)
                        wrows[k * nx + j] += fixp[9 * fq + k];
            }
            /* Each lens reads its row pair with the same weights. */
            for (Py_ssize_t l = 0; l < L; l++) {
                const Py_ssize_t lxl = l ? others[2 * (l - 1)] : xl;
                const Py_ssize_t lxr = l ? others[2 * (l - 1) + 1] : xr;
                float *cols = cols_all + 12 * l * nx;
                Py_ssize_t *block_row = spills + 4 * l, *used = spills + 4 * L + 4 * l;
                const Py_ssize_t *x0 = spills + 8 * L + 4 * l;
                double *lout = out + l * KT * 3;
                const char *bottom = (const char *)fr.buf + (yb + i) * fr.strides[0];
                const char *top = (const char *)fr.buf + (yt - 1 - i) * fr.strides[0];
                const char *start[4] = {bottom + 3 * item * lxr, bottom + 3 * item * (lxl - 1),
                                        top + 3 * item * lxr, top + 3 * item * (lxl - 1)};
                for (int h = 0; h < 4; h++) {
                    float *r = half + (3 * h) * nx;
                    if (linear)
                        split_half((const float *)start[h], h % 2 ? -3 : 3, e, r, r + nx,
                                   r + 2 * nx);
                    else
                        decode_half((const unsigned char *)start[h], h % 2 ? -3 : 3, e, t,
                                    shared, r, r + nx, r + 2 * nx);
                }
                if (use_clip)       /* the bytes just read, still in cache */
                    for (int h = 0; h < 4; h++)
                        clip_half((const unsigned char *)start[h], h % 2 ? -3 : 3, nx, e,
                                  wrows, &clipped, clipped_l00);
                if (use_mid) {
                    for (int h = 0; h < 4; h++) {
                        const Py_ssize_t br = (h < 2 ? yb + i : yt - 1 - i) / f;
                        float *col = cols + (3 * h) * nx;
                        if (br != block_row[h]) {
                            if (block_row[h] >= 0)
                                spill(col, nx, used[h], x0[h], dir[h], f,
                                      MID_ROW(block_row[h]));
                            block_row[h] = br;
                            used[h] = 0;
                        }
                        if (e > used[h])
                            used[h] = e;
                    }
                }
                for (int c = 0; c < 3; c++)
                    if (use_mid)
                        fold_row_sums(half + c * nx, half + (3 + c) * nx, half + (6 + c) * nx,
                                      half + (9 + c) * nx, folds + c * nx,
                                      folds + (3 + c) * nx, folds + (6 + c) * nx,
                                      folds + (9 + c) * nx, cols + c * nx,
                                      cols + (3 + c) * nx, cols + (6 + c) * nx,
                                      cols + (9 + c) * nx, e);
                    else
                        fold_row(half + c * nx, half + (3 + c) * nx, half + (6 + c) * nx,
                                 half + (9 + c) * nx, folds + c * nx, folds + (3 + c) * nx,
                                 folds + (6 + c) * nx, folds + (9 + c) * nx, e);
                /* Runs of up to three weights that meet the same fold (in their order,
                 * grouped by fold). */
                for (Py_ssize_t k = 0; e > 0 && k < KT;) {
                    int m = 1;
                    while (m < 3 && k + m < KT && fold_of[k + m] == fold_of[k])
                        m++;
                    const float *x = folds + (fold_of[k] * 3) * nx;
                    const float *w[3];
                    double *o[3];
                    for (int r = 0; r < m; r++) {
                        const Py_ssize_t row = order[k + r];
                        w[r] = row < 9 ? wrows + row * nx : tab + (row - 9) * nx * ny + i * nx;
                        o[r] = lout + 3 * row;
                    }
                    if (m == 3)
                        dots(w, 3, x, x + nx, x + 2 * nx, e, o);
                    else if (m == 2)
                        dots(w, 2, x, x + nx, x + 2 * nx, e, o);
                    else
                        dots(w, 1, x, x + nx, x + 2 * nx, e, o);
                    k += m;
                }
            }
            /* The bands whose rows every lens has spilled into mid (the spills lag a row
             * pair: the bottom halves' rows above f (yb + i) / f, the top halves' from
             * f ((yt - 1 - i) / f + 1)): their first pass while they are in cache. */
            const Py_ssize_t bot = f * ((yb + i) / f), top = f * ((yt - 1 - i) / f + 1);
            for (Py_ssize_t b = 0; b < nbands; b++) {
                if (bdone[b])
                    continue;
                const Py_ssize_t R0 = b * cf * f;
                const Py_ssize_t R1 = ((b + 1) * cf < mh ? (b + 1) * cf : mh) * f;
                if ((R1 <= yb || R0 >= yb + ny || R1 <= bot)
                    && (R0 >= yt || R1 <= yt - ny || R0 >= top))
                    FIRST_BAND(b);
            }
        }
        for (Py_ssize_t l = 0; use_mid && l < L; l++)
            for (int h = 0; h < 4; h++) {
                const Py_ssize_t br = spills[4 * l + h];
                if (br >= 0)
                    spill(cols_all + (12 * l + 3 * h) * nx, nx, spills[4 * L + 4 * l + h],
                          spills[8 * L + 4 * l + h], dir[h], f, MID_ROW(br));
            }
        for (Py_ssize_t br = 0; fresh && br < H / f; br++)
            if (fresh[br])
                zero(midp + br * mw * 3, mw * 3);
        for (Py_ssize_t b = 0; b < nbands; b++)
            if (!bdone[b])
                FIRST_BAND(b);
        if (use_res) {
            double *rsp = (double *)rsum.buf;
            for (Py_ssize_t k = 0; k < 3 * RC; k++)
                rsp[k] += racc[k];
        }
#undef FIRST_BAND
#undef RESIDUAL_ROW
#undef MID_ROW
        if (use_clip) {
            double *clip = (double *)cl.buf;
            clip[0] += (double)clipped;
            for (int c = 0; c < 3; c++)
                clip[1 + c] += clipped_l00[c];
        }
        Py_END_ALLOW_THREADS
        total_out = ftotal;
        free(racc);
        free(bdone);
        free(fresh);
        free(order);
        free(fold_of);
        free(buf);
        free(spills);
    }
    for (int v = 0; v < NVIEWS; v++)
        if (got[v])
            PyBuffer_Release(&views[v]);
    if (use_first)
        return PyFloat_FromDouble(total_out);
    Py_RETURN_NONE;
fail:
    for (int v = 0; v < NVIEWS; v++)
        if (got[v])
            PyBuffer_Release(&views[v]);
    return NULL;
}

/* count_top(frame, rects): the samples at code 255 of an 8-bit frame (H, W, 3), pixels
 * contiguous, in the rectangles rects, int32 (R, 4) of (r0, r1, a, b): rows r0 <= y < r1,
 * columns a <= x < b, 0 <= r0 <= r1 <= H, 0 <= a <= b <= W (the frame outside a fold's
 * squares, which fold_lens's clip counts: the clip counter's rest, without a mask). */
static PyObject *
count_top(PyObject *self, PyObject *args)
{
    PyObject *frame_obj, *rects_obj;
    if (!PyArg_ParseTuple(args, "OO", &frame_obj, &rects_obj))
        return NULL;
    Py_buffer fr, rc;
    if (get_view(frame_obj, &fr, 0, "B", 3, "frame") < 0)
        return NULL;
    if (get_view(rects_obj, &rc, 0, "i", 2, "rects") < 0) {
        PyBuffer_Release(&fr);
        return NULL;
    }
    const Py_ssize_t H = fr.shape[0], W = fr.shape[1];
    const char *err = NULL;
    if (fr.shape[2] != 3 || fr.strides[2] != 1 || fr.strides[1] != 3)
        err = "frame: (H, W, 3) with contiguous pixels";
    else if (!contiguous(&rc) || rc.shape[1] != 4)
        err = "rects: (R, 4) contiguous int32";
    const int *r = (const int *)rc.buf;
    for (Py_ssize_t q = 0; !err && q < rc.shape[0]; q++, r += 4)
        if (r[0] < 0 || r[0] > r[1] || r[1] > H || r[2] < 0 || r[2] > r[3] || r[3] > W)
            err = "rects: (r0, r1, a, b) with 0 <= r0 <= r1 <= H and 0 <= a <= b <= W";
    if (err) {
        PyErr_SetString(PyExc_ValueError, err);
        PyBuffer_Release(&fr);
        PyBuffer_Release(&rc);
        return NULL;
    }
    Py_ssize_t total = 0;
    Py_BEGIN_ALLOW_THREADS
    r = (const int *)rc.buf;
    for (Py_ssize_t q = 0; q < rc.shape[0]; q++, r += 4)
        for (Py_ssize_t y = r[0]; y < r[1]; y++) {
            const unsigned char *p = (const unsigned char *)fr.buf + y * fr.strides[0]
                                     + 3 * (Py_ssize_t)r[2];
            const Py_ssize_t n = 3 * (Py_ssize_t)(r[3] - r[2]);
            if (any_top(p, n))
                total += count_255(p, n);
        }
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&fr);
    PyBuffer_Release(&rc);
    return PyLong_FromSsize_t(total);
}

static PyMethodDef methods[] = {
    {"fold_lens", fold_lens, METH_VARARGS,
     "fold_lens(frame, table, geometry, others, extents, radial, inv_step, fix_at, fixes, tables, "
     "parities, sums, mid, factor, clear[, clip]): "
     "one lens's folded projection of an 8-bit frame decoded through table (or of a float32 "
     "frame, table None), its block means into mid, and its samples at code 255 and their "
     "L00 weight into clip."},
    {"count_top", count_top, METH_VARARGS,
     "count_top(frame, rects): the samples at code 255 of an 8-bit frame in the rectangles "
     "(R, 4) int32 (r0, r1, a, b)."},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_fold",
    "One lens's folded SH projection of an 8-bit frame, decoded in the same pass.", 0,
    methods, kernel_slots
};

PyMODINIT_FUNC
PyInit__fold(void)
{
    return PyModuleDef_Init(&module);
}
