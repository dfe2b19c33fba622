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
 * samples instead of 24. Up to float rounding (the same float32 samples and weights, added
 * in another order) the coefficients are the numpy path's.
 *
 * equirect_rows(frame, table, rows, acc, counts)
 * (its Python twin, the same signature, numbers and errors: equirect_pass.py)
 *   frame   uint8 (H, W, 3), W even, pixels contiguous (rows may be strided, negative too)
 *   table   float32, 256 entries (one curve) or 768 (per channel, entry v*3 + c)
 *   rows    float32 (K, H) contiguous, K = 6 or 7: the six row functions' weights in the
 *           order above (rows y >= H/2 of the six are not read: the symmetry gives them),
 *           and the up-facing cosine row (every row read; folded as a sum)
 *   acc     float32 (K, W*3) contiguous: acc[k][i] for i < W*3/2 added to, the rest unread
 *   counts  None, or int32 (H, 3) contiguous: written, the samples at code 255 per row and
 *           channel
 *
 * The frame is read in bands of row pairs (y, H-1-y); within a band, four floats of the
 * folded row at a time down all of its pairs, so that the K sums stay in registers and
 * each sample is a byte load, a table load and a share of the adds. Vectors: GCC's and
 * Clang's vector extension (SSE on x86-64, NEON on 64-bit ARM; buffer_check.h's
 * KERNEL_VECTOR), else the scalar loop. No Python object is touched inside the loops, so
 * the GIL is released there. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdlib.h>
#include <string.h>

#include "buffer_check.h"

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
 * row (constant after inlining, as s). */
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

/* C-contiguous, dimensions of length 0 or 1 aside. */
static int
contiguous(const Py_buffer *v)
{
    Py_ssize_t step = v->itemsize;
    for (int d = v->ndim - 1; d >= 0; d--) {
        if (v->shape[d] > 1 && v->strides[d] != step)
            return 0;
        step *= v->shape[d];
    }
    return 1;
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
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t i0 = 0; i0 < pairs; i0 += BAND) {
            const int np = (int)(pairs - i0 < BAND ? pairs - i0 : BAND);
            const unsigned char *top[BAND], *bot[BAND];
            float w[BAND][SLOTS];
#if KERNEL_VECTOR
            v4 wv[BAND][SLOTS];
#endif
            for (int i = 0; i < np; i++) {
                const Py_ssize_t y = i0 + i, b = H - 1 - y;
                top[i] = (const unsigned char *)(base + y * fr.strides[0]);
                bot[i] = (const unsigned char *)(base + b * fr.strides[0]);
                for (int k = 0; k < 6; k++)
                    w[i][k] = r[k * H + y];
                w[i][6] = k7 ? r[6 * H + y] : 0.0f;
                w[i][7] = k7 ? r[6 * H + b] : 0.0f;
#if KERNEL_VECTOR
                for (int k = 0; k < SLOTS; k++)
                    wv[i][k] = (v4){w[i][k], w[i][k], w[i][k], w[i][k]};
#endif
                if (cnt) {
                    count_top(top[i], W, cnt + 3 * y);
                    count_top(bot[i], W, cnt + 3 * b);
                }
            }
            Py_ssize_t j = 0;
#if KERNEL_VECTOR
            const v4 (*wl)[SLOTS] = (const v4 (*)[SLOTS])wv;
            const Py_ssize_t step = fr.strides[0];
            for (; j + 4 <= half; j += 4) {
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
            for (int k = 0; k < 6; k++)
                w[0][k] = r[k * H + y];
            w[0][6] = k7 ? r[6 * H + y] : 0.0f;
            w[0][7] = 0.0f;
            if (cnt)
                count_top(top[0], W, cnt + 3 * y);
            strip_scalar(top, bot, 1, 0, half, t, s, (const float (*)[SLOTS])w, (int)K, acc);
        }
        Py_END_ALLOW_THREADS
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
