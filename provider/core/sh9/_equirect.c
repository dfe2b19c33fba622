/* The separable SH projection of an 8-bit equirect frame, decoded through its table in the
 * same pass over the bytes, and its samples at the top code counted (issue 44).
 *
 * An equirect frame's SH weights are separable (provider/core/geometry/projections.py,
 * Equirect.SEPARABLE_TERMS): the engine sums the decoded rows against 6 row functions of θ
 * (1, cos, sin, cos², sin·cos, sin², times sin θ dθ) into a (6, W·3) accumulator, then
 * contracts its columns with 6 functions of φ. Two symmetries let most products go:
 *
 * - about the equator, row H-1-y weighs as row y for the even functions (1, sin, cos², sin²)
 *   and as minus row y for the odd ones (cos, sin·cos): the two rows are added (subtracted)
 *   before one multiply;
 * - a half turn, column x + W/2 of φ + π: every row function meets only column functions of
 *   one parity under it (cos φ, sin φ odd; 1, sin² φ, sin φ cos φ, cos² φ even), so columns x
 *   and x + W/2 are added (rows 0, 1, 3, 5 and the up row) or subtracted (rows 2, 4) first,
 *   and the accumulator's first half (x < W/2) holds the folded sums, its second half left
 *   as it is (0 in the engine): the column contraction gives the same coefficients.
 *
 * Each weight then multiplies the sum of the four samples that share it: 6 products per 4
 * samples instead of 24, 5 with row 0 not read (sin θ = sin θ cos² θ + sin θ sin² θ: its
 * sums are rows 3's and 5's added). Up to float rounding (the same float32 samples and
 * weights, added in another order; rows 3 and 5 added in float32, both non-negative)
 * the coefficients are the numpy path's.
 *
 * equirect_rows(frame, table, rows, acc, counts)
 * (its Python twin, the same signature, numbers and errors: equirect_pass.py)
 *   frame   uint8 (H, W, 3), W even, pixels contiguous (rows may be strided, negative too)
 *   table   float32, 256 entries (one curve) or 768 (per channel, entry v*3 + c)
 *   rows    float32 (K, H) contiguous, K = 6 or 7: the six row functions' weights in the
 *           order above (rows y >= H/2 of the six are not read: the symmetry gives them;
 *           row 0 not read: rows 3 and 5 added), and the up-facing cosine row (every row
 *           read; folded as a sum)
 *   acc     float32 (K, W*3) contiguous: acc[k][i] for i < W*3/2 added to, the rest unread
 *   counts  None, or int32 (H, 3) contiguous: written, the samples at code 255 per row and
 *           channel
 *
 * The frame is read in bands of row pairs (y, H-1-y); within a band, a strip of the folded
 * row at a time down all of its pairs, so that its sums stay in registers. Without the up
 * row (K = 6, strip_pairs) each byte is looked up in a pair table that holds its value
 * twice, (v, v) or (v, -v), 8 bytes an entry: two columns a vector, the fold is two adds
 * and a butterfly, and each sample costs a byte load and one 8-byte load (x86-64: movq or
 * movhps; aarch64: ldr d, half of them then inserted) instead of a 4-byte load and its
 * insertion into a vector. With it (K = 7, strip) four floats of the folded row a vector,
 * each sample a byte load and a table load. Vectors: GCC's and
 * Clang's vector extension (SSE on x86-64, NEON on 64-bit ARM; buffer_check.h's
 * KERNEL_VECTOR), else the scalar loop. No Python object is touched inside the loops, so
 * the GIL is released there. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "buffer_check.h"

#if KERNEL_VECTOR && defined(__SSE2__)
#include <emmintrin.h>
#elif KERNEL_VECTOR && defined(__ARM_NEON)
#include <arm_neon.h>
#endif

/* Row pairs a band: the pairs' broadcast weights stay in L1 (32 x 8 x 16 bytes). */
#define BAND 32
/* The up row's weights of a pair: top and bottom (slots 6 and 7). */
#define SLOTS 8

#if KERNEL_VECTOR
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

/* Four decoded samples from bytes p[0..3]; lane l's table tl[l] (its channel's curve) read
 * at p[l] * s (s = 1: one curve; 3: per channel). */
KERNEL_INLINE v4
gather(const unsigned char *p, const float *const *tl, int s)
{
    return (v4){tl[0][p[0] * s], tl[1][p[1] * s], tl[2][p[2] * s], tl[3][p[3] * s]};
}

/* Folded samples [j, j + 4) of the band's np pairs added to acc's K rows: the pairs' top
 * rows from top (step apart, downwards), their bottom rows from bot (upwards). up: the 7th
 * row (constant after inlining, as s). The path of K = 7 (row 0's weights w[0] those of
 * rows 3 and 5 added, as in strip_pairs). */
KERNEL_INLINE void
strip(const unsigned char *top, const unsigned char *bot, Py_ssize_t step, int np,
      Py_ssize_t j, Py_ssize_t half, const float *t, int s, const v4 (*w)[SLOTS], int up,
      float *const *acc)
{
    const float *tl[4];
    for (int l = 0; l < 4; l++)
        tl[l] = s == 1 ? t : t + (j + l) % 3;
    v4 a0 = load4(acc[0] + j), a1 = load4(acc[1] + j), a2 = load4(acc[2] + j);
    v4 a3 = load4(acc[3] + j), a4 = load4(acc[4] + j), a5 = load4(acc[5] + j);
    v4 a6 = up ? load4(acc[6] + j) : (v4){0, 0, 0, 0};
    const unsigned char *pt = top + j, *pb = bot + j;
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC unroll 2
#endif
    for (const v4 (*wi)[SLOTS] = w; wi < w + np; wi++, pt += step, pb -= step) {
        const v4 t1 = gather(pt, tl, s), t2 = gather(pt + half, tl, s);
        const v4 b1 = gather(pb, tl, s), b2 = gather(pb + half, tl, s);
        const v4 ptop = t1 + t2, qtop = t1 - t2, pbot = b1 + b2, qbot = b1 - b2;
        const v4 pp = ptop + pbot, pd = ptop - pbot, qp = qtop + qbot, qd = qtop - qbot;
        a0 += (*wi)[0] * pp;
        a1 += (*wi)[1] * pd;
        a2 += (*wi)[2] * qp;
        a3 += (*wi)[3] * pp;
        a4 += (*wi)[4] * qd;
        a5 += (*wi)[5] * pp;
        if (up)
            a6 += (*wi)[6] * ptop + (*wi)[7] * pbot;
    }
    store4(acc[0] + j, a0); store4(acc[1] + j, a1); store4(acc[2] + j, a2);
    store4(acc[3] + j, a3); store4(acc[4] + j, a4); store4(acc[5] + j, a5);
    if (up)
        store4(acc[6] + j, a6);
}

/* Two folded columns' entries of a pair table in one vector: entry a of table e in lanes
 * 0 and 1, entry b of table f in lanes 2 and 3 (8 bytes an entry); two 8-byte loads, movq
 * and movhps on x86-64, ldr d and ins on aarch64. */
KERNEL_INLINE v4
two(const char *e, unsigned a, const char *f, unsigned b)
{
    double d[2];
    memcpy(&d[0], e + (size_t)a * 8, 8);
    memcpy(&d[1], f + (size_t)b * 8, 8);
    typedef double v2d __attribute__((vector_size(16)));
    return (v4)(v2d){d[0], d[1]};
}

/* The path of K = 6: folded columns [j, j + 4) of the band's np pairs, two columns a
 * vector. Each byte is looked up in a pair table, its decoded value v twice: (v, v) for a
 * top row's samples (pt: t1, t2), (v, -v) for a bottom row's (tb: b1, b2), so that
 *   s1 = t1 + b1, s2 = t2 + b2: lo = s1 + s2 = (pp, pd), hi = s1 - s2 = (qp, qd)
 * per column (pp = t1 + t2 + b1 + b2, pd = t1 + t2 - b1 - b2, qp = t1 - t2 + b1 - b2,
 * qd = t1 - t2 - b1 + b2): the fold is two adds and a butterfly per two columns, and its
 * four results are each one lane, weighed by one vector: lo by (w3, w1) into sa, by
 * (w5, 0) into sb, hi by (w2, w4) into sh. The sums per column and lane are kept in sums
 * (6 vectors a strip of four columns) from band to band; row 0 is rows 3 and 5 added at
 * the end (sin θ = sin θ cos² θ + sin θ sin² θ). s: 1, or 3 (a table a channel). */
KERNEL_INLINE void
strip_pairs(const unsigned char *top, const unsigned char *bot, Py_ssize_t step, int np,
            Py_ssize_t j, Py_ssize_t half, const float *pairs, int s, const v4 (*w)[3],
            v4 *sums, int first)
{
    const char *pt[4], *tb[4];
    for (int c = 0; c < 4; c++) {
        pt[c] = (const char *)(pairs + (s == 1 ? 0 : (j + c) % 3) * 1024);
        tb[c] = pt[c] + 2048;
    }
    const v4 zero = {0, 0, 0, 0};      /* the first band starts the sums */
    v4 sa0 = first ? zero : sums[0], sb0 = first ? zero : sums[1], sh0 = first ? zero : sums[2];
    v4 sa1 = first ? zero : sums[3], sb1 = first ? zero : sums[4], sh1 = first ? zero : sums[5];
    const unsigned char *p = top + j, *q = bot + j;
#define FOLD(p, q, w, c, sa, sb, sh)                                                 \
    do {                                                                             \
        const v4 s1 = two(pt[c], p[c], pt[c + 1], p[c + 1])                          \
            + two(tb[c], q[c], tb[c + 1], q[c + 1]);                                 \
        const v4 s2 = two(pt[c], p[half + c], pt[c + 1], p[half + c + 1])            \
            + two(tb[c], q[half + c], tb[c + 1], q[half + c + 1]);                   \
        const v4 lo = s1 + s2, hi = s1 - s2;                                         \
        sa += (w)[0] * lo;                                                           \
        sb += (w)[1] * lo;                                                           \
        sh += (w)[2] * hi;                                                           \
    } while (0)
    /* two pairs a turn, the second's rows a step from the first's (indexed loads) */
    const v4 (*wi)[3] = w;
    for (; wi + 2 <= w + np; wi += 2, p += 2 * step, q -= 2 * step) {
        const unsigned char *p1 = p + step, *q1 = q - step;
        FOLD(p, q, wi[0], 0, sa0, sb0, sh0);
        FOLD(p, q, wi[0], 2, sa1, sb1, sh1);
        FOLD(p1, q1, wi[1], 0, sa0, sb0, sh0);
        FOLD(p1, q1, wi[1], 2, sa1, sb1, sh1);
    }
    if (wi < w + np) {
        FOLD(p, q, wi[0], 0, sa0, sb0, sh0);
        FOLD(p, q, wi[0], 2, sa1, sb1, sh1);
    }
#undef FOLD
    sums[0] = sa0; sums[1] = sb0; sums[2] = sh0; sums[3] = sa1; sums[4] = sb1; sums[5] = sh1;
}
#endif

/* The same for folded samples [j0, half) one at a time (the vectors' tail, the scalar
 * build, and the middle row of an odd height: bot[i] NULL, its weights the row's own). */
static void
strip_scalar(const unsigned char *const *top, const unsigned char *const *bot, int np,
             Py_ssize_t j0, Py_ssize_t half, const float *t, int s, const float (*w)[SLOTS],
             int K, float *const *acc)
{
    for (Py_ssize_t j = j0; j < half; j++) {
        const float *tc = s == 1 ? t : t + j % 3;
        float a[7];
        for (int k = 0; k < K; k++)
            a[k] = acc[k][j];
        for (int i = 0; i < np; i++) {
            const float t1 = tc[top[i][j] * s], t2 = tc[top[i][j + half] * s];
            const float b1 = bot[i] ? tc[bot[i][j] * s] : 0.0f;
            const float b2 = bot[i] ? tc[bot[i][j + half] * s] : 0.0f;
            const float ptop = t1 + t2, qtop = t1 - t2, pbot = b1 + b2, qbot = b1 - b2;
            const float pp = ptop + pbot, pd = ptop - pbot, qp = qtop + qbot, qd = qtop - qbot;
            a[0] += w[i][0] * pp;
            a[1] += w[i][1] * pd;
            a[2] += w[i][2] * qp;
            a[3] += w[i][3] * pp;
            a[4] += w[i][4] * qd;
            a[5] += w[i][5] * pp;
            if (K == 7)
                a[6] += w[i][6] * ptop + w[i][7] * pbot;
        }
        for (int k = 0; k < K; k++)
            acc[k][j] = a[k];
    }
}

/* Samples at code 255 of a row of n pixels, per channel, into out[3]: first whether any
 * sample clips, 64 bytes a turn (16-byte compares where vectors are at hand), then, where
 * one does, the count, 48 bytes a turn (an overexposed sky costs a compare a sample, not
 * a scalar loop). */
static void
count_top(const unsigned char *restrict p, Py_ssize_t n, int *restrict out)
{
    Py_ssize_t i = 0;
    int any = 0;
#if KERNEL_VECTOR
    typedef unsigned char u16 __attribute__((vector_size(16)));
#if defined(__SSE2__) || defined(__ARM_NEON)
    /* The bytes' maximum, 128 a turn: a load and a max for 16 bytes (pmaxub, umax). */
#if defined(__SSE2__)
    typedef __m128i bytes;
#define LOAD(q) _mm_loadu_si128((const __m128i *)(q))
#define MAX(a, b) _mm_max_epu8(a, b)
    bytes m = _mm_setzero_si128();
#else
    typedef uint8x16_t bytes;
#define LOAD(q) vld1q_u8(q)
#define MAX(a, b) vmaxq_u8(a, b)
    bytes m = vdupq_n_u8(0);
#endif
    for (; i + 128 <= 3 * n; i += 128) {
        const unsigned char *q = p + i;
        const bytes a = MAX(LOAD(q), LOAD(q + 16)), b = MAX(LOAD(q + 32), LOAD(q + 48));
        const bytes c = MAX(LOAD(q + 64), LOAD(q + 80)), d = MAX(LOAD(q + 96), LOAD(q + 112));
        m = MAX(m, MAX(MAX(a, b), MAX(c, d)));
    }
#undef LOAD
#undef MAX
    unsigned char top[16];
    memcpy(top, &m, 16);
    for (int l = 0; l < 16; l++)
        any |= top[l] == 255;
#else
    u16 hit = {0};
    for (; i + 64 <= 3 * n; i += 64) {
        u16 v0, v1, v2, v3;
        memcpy(&v0, p + i, 16);
        memcpy(&v1, p + i + 16, 16);
        memcpy(&v2, p + i + 32, 16);
        memcpy(&v3, p + i + 48, 16);
        /* (hit = hit | ..., not |=: GCC compiles the latter as a select) */
        hit = hit | (u16)((v0 == 255) | (v1 == 255) | (v2 == 255) | (v3 == 255));
    }
    long long lanes[2];
    memcpy(lanes, &hit, sizeof lanes);
    any = (lanes[0] | lanes[1]) != 0;
#endif
#endif
    for (; !any && i < 3 * n; i++)
        any = p[i] == 255;
    out[0] = out[1] = out[2] = 0;
    if (!any)
        return;
    i = 0;
#if KERNEL_VECTOR
    /* Lane l of the k-th 16 bytes holds channel (k + l) % 3; byte counters (a compare's
     * -1 subtracted), emptied every 255 turns, before they wrap. */
    while (i + 48 <= 3 * n) {
        u16 c0 = {0}, c1 = {0}, c2 = {0};
        for (int turn = 0; turn < 255 && i + 48 <= 3 * n; turn++, i += 48) {
            u16 v0, v1, v2;
            memcpy(&v0, p + i, 16);
            memcpy(&v1, p + i + 16, 16);
            memcpy(&v2, p + i + 32, 16);
            c0 = c0 - (u16)(v0 == 255);
            c1 = c1 - (u16)(v1 == 255);
            c2 = c2 - (u16)(v2 == 255);
        }
        for (int l = 0; l < 16; l++) {
            out[l % 3] += c0[l];
            out[(l + 1) % 3] += c1[l];
            out[(l + 2) % 3] += c2[l];
        }
    }
#endif
    for (; i < 3 * n; i++)          /* i is a whole number of pixels here */
        out[i % 3] += p[i] == 255;
}

static PyObject *
equirect_rows(PyObject *self, PyObject *args)
{
    PyObject *frame_obj, *table_obj, *rows_obj, *acc_obj, *counts_obj;
    if (!PyArg_ParseTuple(args, "OOOOO", &frame_obj, &table_obj, &rows_obj, &acc_obj,
                          &counts_obj))
        return NULL;
    Py_buffer views[5];
    int got[5] = {0, 0, 0, 0, 0};
    const int use_counts = counts_obj != Py_None;
    const char *err = NULL;
#define VIEW(n, obj, w, fmt, nd, name) \
    do { if (get_view(obj, &views[n], w, fmt, nd, name) < 0) goto fail; got[n] = 1; } while (0)
    VIEW(0, frame_obj, 0, "B", 3, "frame");
    VIEW(1, table_obj, 0, "f", 1, "table");
    VIEW(2, rows_obj, 0, "f", 2, "rows");
    VIEW(3, acc_obj, 1, "f", 2, "acc");
    if (use_counts)
        VIEW(4, counts_obj, 1, "i", 2, "counts");
#undef VIEW
    Py_buffer fr = views[0], tb = views[1], rw = views[2], ac = views[3], ct = views[4];
    const Py_ssize_t H = fr.shape[0], W = fr.shape[1], K = rw.shape[0];
    if (fr.shape[2] != 3 || fr.strides[2] != 1 || fr.strides[1] != 3 || W % 2 != 0)
        err = "frame: (H, W, 3) with W even and contiguous pixels";
    else if (!contiguous(&tb) || (tb.shape[0] != 256 && tb.shape[0] != 768))
        err = "table: 256 contiguous entries, or 768 (per channel)";
    else if ((K != 6 && K != 7) || rw.shape[1] != H || !contiguous(&rw))
        err = "rows: (6 or 7, H) contiguous float32";
    else if (ac.shape[0] != K || ac.shape[1] != 3 * W || !contiguous(&ac))
        err = "acc: (K, W * 3) contiguous float32";
    else if (use_counts && (ct.shape[0] != H || ct.shape[1] != 3 || !contiguous(&ct)))
        err = "counts: (H, 3) contiguous int32";
    if (err) {
        PyErr_SetString(PyExc_ValueError, err);
        goto fail;
    }
    {
        const Py_ssize_t half = 3 * W / 2;
        const float *t = (const float *)tb.buf, *r = (const float *)rw.buf;
        const int s = tb.shape[0] == 256 ? 1 : 3;
        const int k7 = K == 7;
        float *acc[7];
        for (int k = 0; k < K; k++)
            acc[k] = (float *)ac.buf + k * 3 * W;
        int *cnt = use_counts ? (int *)ct.buf : NULL;
        const char *base = (const char *)fr.buf;
        const Py_ssize_t pairs = H / 2;
#if KERNEL_VECTOR
        /* K = 6: the pair tables (1024 floats a channel: (v, v) then (v, -v) per code) and
         * the sums of each strip of four columns (6 vectors), 16-byte aligned. */
        const Py_ssize_t strips = k7 || pairs == 0 ? 0 : half / 4;
        void *scratch = NULL;
        float *pair_t = NULL;
        v4 *sums = NULL;
        if (strips) {
            const size_t n = (size_t)s * 1024 * sizeof(float) + (size_t)strips * 6 * sizeof(v4);
            scratch = malloc(n + 16);
            if (!scratch) {
                PyErr_NoMemory();
                goto fail;
            }
            pair_t = (float *)(((uintptr_t)scratch + 15) & ~(uintptr_t)15);
            sums = (v4 *)(pair_t + s * 1024);
        }
#endif
        Py_BEGIN_ALLOW_THREADS
#if KERNEL_VECTOR
        for (int c = 0; strips && c < s; c++)
            for (int v = 0; v < 256; v++) {
                const float x = t[v * s + c];
                float *e = pair_t + c * 1024 + 2 * v;
                e[0] = e[1] = e[512] = x;
                e[513] = -x;
            }
#endif
        for (Py_ssize_t i0 = 0; i0 < pairs; i0 += BAND) {
            const int np = (int)(pairs - i0 < BAND ? pairs - i0 : BAND);
            const unsigned char *top[BAND], *bot[BAND];
            float w[BAND][SLOTS];
#if KERNEL_VECTOR
            v4 wv[BAND][SLOTS], wp[BAND][3];
#endif
            for (int i = 0; i < np; i++) {
                const Py_ssize_t y = i0 + i, b = H - 1 - y;
                top[i] = (const unsigned char *)(base + y * fr.strides[0]);
                bot[i] = (const unsigned char *)(base + b * fr.strides[0]);
                for (int k = 1; k < 6; k++)
                    w[i][k] = r[k * H + y];
                w[i][0] = w[i][3] + w[i][5];   /* sin θ = sin θ (cos² θ + sin² θ) */
                w[i][6] = k7 ? r[6 * H + y] : 0.0f;
                w[i][7] = k7 ? r[6 * H + b] : 0.0f;
#if KERNEL_VECTOR
                for (int k = 0; k < SLOTS; k++)
                    wv[i][k] = (v4){w[i][k], w[i][k], w[i][k], w[i][k]};
                wp[i][0] = (v4){w[i][3], w[i][1], w[i][3], w[i][1]};
                wp[i][1] = (v4){w[i][5], 0.0f, w[i][5], 0.0f};
                wp[i][2] = (v4){w[i][2], w[i][4], w[i][2], w[i][4]};
#endif
                if (cnt) {
                    count_top(top[i], W, cnt + 3 * y);
                    count_top(bot[i], W, cnt + 3 * b);
                }
            }
            Py_ssize_t j = 0;
#if KERNEL_VECTOR
            const v4 (*wl)[SLOTS] = (const v4 (*)[SLOTS])wv;
            const v4 (*wq)[3] = (const v4 (*)[3])wp;
            const Py_ssize_t step = fr.strides[0];
            for (; strips && j + 4 <= half; j += 4) {
                if (s == 1)
                    strip_pairs(top[0], bot[0], step, np, j, half, pair_t, 1, wq, sums + j / 4 * 6,
                                i0 == 0);
                else
                    strip_pairs(top[0], bot[0], step, np, j, half, pair_t, 3, wq, sums + j / 4 * 6,
                                i0 == 0);
            }
            for (; !strips && j + 4 <= half; j += 4) {
                if (s == 1 && !k7)
                    strip(top[0], bot[0], step, np, j, half, t, 1, wl, 0, acc);
                else if (s == 1)
                    strip(top[0], bot[0], step, np, j, half, t, 1, wl, 1, acc);
                else if (!k7)
                    strip(top[0], bot[0], step, np, j, half, t, 3, wl, 0, acc);
                else
                    strip(top[0], bot[0], step, np, j, half, t, 3, wl, 1, acc);
            }
#endif
            strip_scalar(top, bot, np, j, half, t, s, (const float (*)[SLOTS])w, (int)K, acc);
        }
        if (H % 2) {                   /* the middle row: alone, its own weights */
            const Py_ssize_t y = H / 2;
            const unsigned char *top[1] = {(const unsigned char *)(base + y * fr.strides[0])};
            const unsigned char *bot[1] = {NULL};
            float w[1][SLOTS];
            for (int k = 1; k < 6; k++)
                w[0][k] = r[k * H + y];
            w[0][0] = w[0][3] + w[0][5];
            w[0][6] = k7 ? r[6 * H + y] : 0.0f;
            w[0][7] = 0.0f;
            if (cnt)
                count_top(top[0], W, cnt + 3 * y);
            strip_scalar(top, bot, 1, 0, half, t, s, (const float (*)[SLOTS])w, (int)K, acc);
        }
#if KERNEL_VECTOR
        /* The strips' sums into acc: lanes (2e, 2e + 1) of a vector are column j's. */
        for (Py_ssize_t m = 0; m < strips; m++)
            for (int g = 0; g < 2; g++)
                for (int e = 0; e < 2; e++) {
                    const Py_ssize_t j = 4 * m + 2 * g + e;
                    const v4 sa = sums[6 * m + 3 * g], sb = sums[6 * m + 3 * g + 1];
                    const v4 sh = sums[6 * m + 3 * g + 2];
                    acc[0][j] += sa[2 * e] + sb[2 * e];
                    acc[1][j] += sa[2 * e + 1];
                    acc[2][j] += sh[2 * e];
                    acc[3][j] += sa[2 * e];
                    acc[4][j] += sh[2 * e + 1];
                    acc[5][j] += sb[2 * e];
                }
#endif
        Py_END_ALLOW_THREADS
#if KERNEL_VECTOR
        free(scratch);
#endif
    }
    for (int v = 0; v < 5; v++)
        if (got[v])
            PyBuffer_Release(&views[v]);
    Py_RETURN_NONE;
fail:
    for (int v = 0; v < 5; v++)
        if (got[v])
            PyBuffer_Release(&views[v]);
    return NULL;
}

static PyMethodDef methods[] = {
    {"equirect_rows", equirect_rows, METH_VARARGS,
     "equirect_rows(frame, table, rows, acc, counts): an 8-bit equirect frame decoded "
     "through table and summed against its row weights, folded by its symmetries, into "
     "acc's first half; counts: its samples at code 255 per row and channel."},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_equirect",
    "An 8-bit equirect frame's separable SH projection, decoded in the same pass.", 0,
    methods, kernel_slots
};

PyMODINIT_FUNC
PyInit__equirect(void)
{
    return PyModuleDef_Init(&module);
}
