/* The lights' per-frame sums (issue 44): the mid copy's first pass, the truth at the
 * normals from the coarse rest by caps of normals, and the candidates' excess irradiance
 * at the normals their horizon cuts.
 *
 * first_pass(mid, scale, luma, omega, Y, coarse, factor, Ymax) -> total
 *   mid      float32 (h, w, 3) contiguous, scaled by (float) scale in place (the fold
 *            kernel's block sums to means; 1: left as it is)
 *   luma     float32 (3,): the luminance weights
 *   omega    float32 (h, w) contiguous: each mid pixel's solid angle (0 where unseen)
 *   Y        float32 (h, w) contiguous, written: luma . rgb, in that order
 *   coarse   None, or float32 (hc, wc, 3) contiguous, written: the means of mid's
 *            factor x factor blocks, hc * factor <= h, wc * factor <= w
 *   Ymax     float32 (h,) contiguous, written: each row's largest Y (-inf where none is
 *            above it: a NaN never is), so that the pixels above a threshold are looked
 *            for in the rows that hold some (a lit Theta S frame's: 33 of 144)
 *   total    sum of Y w (float32 products, a double sum)
 * One pass over the mid copy a band of factor rows at a time, each band in cache for its
 * scale, luminance, flux and block means (numpy and OpenCV took a call and a temporary
 * each: 1.6 MB of a Cortex-A53's DRAM traffic a lit Theta frame, and 2.2 M instructions).
 * Its twin: provider/core/lights/first_pass.py, first_pass_twin.
 *
 *
 * truth_caps(x, dw, core, core_at, band, band_at, normals, out)
 *   x        float32 (P, 3) contiguous: each seeing coarse pixel's radiance (the rest)
 *   dw       float32 (P, 3) contiguous: its direction times its solid angle, d w
 *   core     uint16 (Nc,): the pixels of each cap's core, cap i's at core_at[i]..
 *            core_at[i+1] (16 bits: the lists are read every frame, 0.23 MB of a Theta S's
 *            traffic in 32 bits; a coarse grid past 65,536 seeing pixels takes the dense
 *            kernel, provider/core/lights/coarse_truth.py)
 *   core_at  int32 (caps + 1,): 0, then non-decreasing, the last Nc
 *   band     uint16 (Nb,): the pixels of each cap's horizon band, cap i's at band_at[i]..
 *   band_at  int32 (caps + 1,): 0, then non-decreasing, the last Nb
 *   normals  float64 (caps, k, 3): each cap's normals (zero rows pad a short cap)
 *   out      float64 (caps, k, 3), written: sum_p max(0, n.d_p) w_p x_p at each normal
 *
 * A cap of normals sees every pixel of its core at a positive cosine from each of its
 * normals, so there the sum is linear, n . (sum of d w x^T over the core): one 3 x 3 sum a
 * cap; and none of the pixels behind its horizon band. Only the band takes a product a
 * normal and pixel: for the Theta S's 256 normals in caps of 8, 41 % of the dense
 * kernel's (provider/core/lights/coarse_truth.py says how the caps are cut). Its entries,
 * max(0, n . d w) (w > 0), are made in registers from the band's d w, not read: a stored
 * band kernel (1.1 MB for a Theta S; the dense one 2.7 MB) crossed the memory bus every
 * frame on a Cortex-A53's 512 KB cache.
 *
 * Its Python twin, the same signature, numbers (to float rounding) and errors:
 * coarse_truth.truth_caps_twin. Sums in float32 (a cap's core and each band row, the
 * band's cosines from the normals rounded to float32), the products with the normals in
 * float64.
 *
 * excess_rows(dirs, flux, normals, rows, out)
 *   dirs     float32 (n, 3) contiguous: a bright region's pixel directions
 *   flux     float32 (n, 3) contiguous: their excess radiance times solid angle
 *   normals  float32 (N, 3) contiguous
 *   rows     int32 (k,): the normals whose horizon cuts the region (indices in [0, N))
 *   out      float64 (N, 3), accumulated: out[r] += sum_j max(0, n_r.d_j) f_j, r in rows
 *
 * The candidates' excess irradiance at the normals that the region's horizon cuts
 * (provider/core/lights/caps.py takes the others linearly). numpy made a (rows x n)
 * kernel block with sgemm, clipped it and read it back a channel at a time: 6.5 M
 * instructions and 1.1 MB of a Cortex-A53's DRAM traffic a lit Theta frame; here each
 * product is made and used in registers, the region's planes (24 bytes a pixel) in cache.
 * Its twin: caps.excess_rows_twin. Sums in float32 (each row), added to out in float64. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdlib.h>
#include <string.h>

#include "buffer_check.h"
#include "first_pass_band.h"

#if KERNEL_VECTOR
typedef float v4 __attribute__((vector_size(16)));
#endif

/* every 16-bit index below P: eight compares at a time, no early exit (the caps' lists are
 * checked every call: ~60 k of them for a Theta S) */
static int
below(const unsigned short *idx, Py_ssize_t n, Py_ssize_t P)
{
    if (P > 65535)
        return 1;
    Py_ssize_t j = 0;
    int bad = 0;
#if KERNEL_VECTOR
    typedef unsigned short v8u __attribute__((vector_size(16)));
    typedef short v8s __attribute__((vector_size(16)));
    const unsigned short t = (unsigned short)P;
    const v8u top = {t, t, t, t, t, t, t, t};
    v8s any = {0, 0, 0, 0, 0, 0, 0, 0};
    for (; j + 8 <= n; j += 8) {
        v8u q;
        memcpy(&q, idx + j, sizeof q);
        any |= (q >= top);
    }
    for (int k = 0; k < 8; k++)
        bad |= any[k];
#endif
    for (; j < n; j++)
        bad |= idx[j] >= P;
    return !bad;
}

/* offsets: 0 first, non-decreasing, n last */
static int
offsets_ok(const int *at, Py_ssize_t caps, Py_ssize_t n)
{
    if (at[0] != 0 || at[caps] != n)
        return 0;
    for (Py_ssize_t i = 0; i < caps; i++)
        if (at[i + 1] < at[i])
            return 0;
    return 1;
}

/* every index in [0, P) (P < 2^31): four compares at a time, no early exit (excess_rows'
 * normals; the caps' 16-bit lists take below()) */
static int
indices_ok(const int *idx, Py_ssize_t n, Py_ssize_t P)
{
    Py_ssize_t j = 0;
    int bad = 0;
#if KERNEL_VECTOR
    typedef int v4i __attribute__((vector_size(16)));
    const v4i zero = {0, 0, 0, 0}, top = {(int)P, (int)P, (int)P, (int)P};
    v4i any = zero;
    for (; j + 4 <= n; j += 4) {
        v4i q;
        memcpy(&q, idx + j, sizeof q);
        any |= (q < zero) | (q >= top);
    }
    bad = any[0] | any[1] | any[2] | any[3];
#endif
    for (; j < n; j++)
        bad |= idx[j] < 0 || idx[j] >= P;
    return !bad;
}

/* the longest band (at least 1): its planes' length */
static Py_ssize_t
widest_of(const int *at, Py_ssize_t caps)
{
    Py_ssize_t widest = 1;
    for (Py_ssize_t i = 0; i < caps; i++)
        if (at[i + 1] - at[i] > widest)
            widest = at[i + 1] - at[i];
    return widest;
}

/* The 3 channels' sums over one region of max(0, n.d_j) f_j for one normal n. */
static inline void
row_excess(const float *n, const float *restrict d0, const float *restrict d1,
           const float *restrict d2, const float *restrict f0, const float *restrict f1,
           const float *restrict f2, Py_ssize_t m, float *s)
{
    Py_ssize_t j = 0;
    float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f;
    const float n0 = n[0], n1 = n[1], n2 = n[2];
#if KERNEL_VECTOR
    typedef int v4i __attribute__((vector_size(16)));
    const v4 zero = {0, 0, 0, 0};
    v4 a0 = zero, a1 = zero, a2 = zero;
    for (; j + 4 <= m; j += 4) {
        v4 x0, x1, x2, c;
        memcpy(&x0, d0 + j, sizeof x0);
        memcpy(&x1, d1 + j, sizeof x1);
        memcpy(&x2, d2 + j, sizeof x2);
        c = (n0 * x0 + n1 * x1) + n2 * x2;
        c = (v4)((v4i)c & (c > zero));        /* max(0, c); 0 for a NaN, as below */
        memcpy(&x0, f0 + j, sizeof x0);
        memcpy(&x1, f1 + j, sizeof x1);
        memcpy(&x2, f2 + j, sizeof x2);
        a0 += c * x0;
        a1 += c * x1;
        a2 += c * x2;
    }
    s0 = (a0[0] + a0[1]) + (a0[2] + a0[3]);
    s1 = (a1[0] + a1[1]) + (a1[2] + a1[3]);
    s2 = (a2[0] + a2[1]) + (a2[2] + a2[3]);
#endif
    for (; j < m; j++) {
        float c = (n0 * d0[j] + n1 * d1[j]) + n2 * d2[j];
        c = c > 0.0f ? c : 0.0f;
        s0 += c * f0[j];
        s1 += c * f1[j];
        s2 += c * f2[j];
    }
    s[0] = s0;
    s[1] = s1;
    s[2] = s2;
}

static PyObject *
truth_caps(PyObject *self, PyObject *args)
{
    PyObject *obj[8];
    if (!PyArg_ParseTuple(args, "OOOOOOOO", &obj[0], &obj[1], &obj[2], &obj[3], &obj[4],
                          &obj[5], &obj[6], &obj[7]))
        return NULL;
    static const char *fmt[8] = {"f", "f", "H", "i", "H", "i", "d", "d"};
    static const int nd[8] = {2, 2, 1, 1, 1, 1, 3, 3};
    static const char *name[8] = {"x", "dw", "core", "core_at", "band", "band_at",
                                  "normals", "out"};
    Py_buffer v[8];
    int got = 0;
    for (; got < 8; got++)
        if (get_view(obj[got], &v[got], got == 7, fmt[got], nd[got], name[got]) < 0)
            break;
    const char *err = NULL;
    if (got == 8) {
        for (int i = 0; i < 8 && !err; i++)
            if (!contiguous(&v[i]))
                err = "every array: C-contiguous";
    }
    Py_ssize_t P = 0, caps = 0, k = 0, Nc = 0, Nb = 0;
    if (got == 8 && !err) {
        P = v[0].shape[0];
        caps = v[6].shape[0];
        k = v[6].shape[1];
        Nc = v[2].shape[0];
        Nb = v[4].shape[0];
        if (v[0].shape[1] != 3 || v[1].shape[0] != P || v[1].shape[1] != 3)
            err = "x, dw: (P, 3) float32";
        else if (v[6].shape[2] != 3 || v[7].shape[0] != caps || v[7].shape[1] != k
                 || v[7].shape[2] != 3)
            err = "normals, out: (caps, k, 3) float64";
        else if (v[3].shape[0] != caps + 1 || v[5].shape[0] != caps + 1)
            err = "core_at, band_at: (caps + 1,) int32";
        else if (!offsets_ok((const int *)v[3].buf, caps, Nc)
                 || !offsets_ok((const int *)v[5].buf, caps, Nb))
            err = "core_at, band_at: 0, non-decreasing, ending at the indices' length";
        else if (!below((const unsigned short *)v[2].buf, Nc, P)
                 || !below((const unsigned short *)v[4].buf, Nb, P))
            err = "core, band: pixel indices in [0, P)";
    }
    if (got == 8 && err)
        PyErr_SetString(PyExc_ValueError, err);
    float *planes = NULL;
    Py_ssize_t widest = 1;
    if (got == 8 && !err) {
        widest = widest_of((const int *)v[5].buf, caps);
        /* the band's planes (x, then d w), then x padded to 4 floats a pixel (the cores'
         * vector loads) */
        planes = (float *)malloc(sizeof(float) * (size_t)(6 * widest + 4 * P + 4));
        if (planes == NULL) {
            PyErr_NoMemory();
            err = "memory";
        }
    }
    if (got < 8 || err) {
        for (int i = 0; i < got; i++)
            PyBuffer_Release(&v[i]);
        return NULL;
    }
    const float *x = (const float *)v[0].buf, *dw = (const float *)v[1].buf;
    const unsigned short *core = (const unsigned short *)v[2].buf;
    const unsigned short *band = (const unsigned short *)v[4].buf;
    const int *core_at = (const int *)v[3].buf, *band_at = (const int *)v[5].buf;
    const double *normals = (const double *)v[6].buf;
    double *out = (double *)v[7].buf;
    Py_BEGIN_ALLOW_THREADS
    float *x4 = planes + 6 * widest;
    for (Py_ssize_t p = 0; p < P; p++) {
        x4[4 * p] = x[3 * p];
        x4[4 * p + 1] = x[3 * p + 1];
        x4[4 * p + 2] = x[3 * p + 2];
        x4[4 * p + 3] = 0.0f;
    }
    for (Py_ssize_t i = 0; i < caps; i++) {
        /* the core: sum of d w x^T, S[a][c] */
        float S[3][4];
#if KERNEL_VECTOR
        v4 s0 = {0, 0, 0, 0}, s1 = s0, s2 = s0;
        for (Py_ssize_t q = core_at[i]; q < core_at[i + 1]; q++) {
            const Py_ssize_t p = core[q];
            v4 r;
            memcpy(&r, x4 + 4 * p, sizeof r);
            s0 += dw[3 * p] * r;
            s1 += dw[3 * p + 1] * r;
            s2 += dw[3 * p + 2] * r;
        }
        memcpy(S[0], &s0, sizeof s0);
        memcpy(S[1], &s1, sizeof s1);
        memcpy(S[2], &s2, sizeof s2);
#else
        memset(S, 0, sizeof S);
        for (Py_ssize_t q = core_at[i]; q < core_at[i + 1]; q++) {
            const float *d = dw + 3 * (Py_ssize_t)core[q], *r = x4 + 4 * (Py_ssize_t)core[q];
            for (int a = 0; a < 3; a++)
                for (int c = 0; c < 3; c++)
                    S[a][c] += d[a] * r[c];
        }
#endif
        /* the band's d w and radiance gathered into planes, then each normal's sums */
        const Py_ssize_t b0 = band_at[i], m = band_at[i + 1] - b0;
        for (Py_ssize_t j = 0; j < m; j++) {
            const Py_ssize_t p = band[b0 + j];
            const float *r = x4 + 4 * p;
            for (int a = 0; a < 3; a++) {
                planes[a * m + j] = dw[3 * p + a];
                planes[(3 + a) * m + j] = r[a];
            }
        }
        for (Py_ssize_t r = 0; r < k; r++) {
            float s[3];
            const double *n = normals + 3 * (i * k + r);
            const float n32[3] = {(float)n[0], (float)n[1], (float)n[2]};
            row_excess(n32, planes, planes + m, planes + 2 * m, planes + 3 * m,
                       planes + 4 * m, planes + 5 * m, m, s);
            double *o = out + 3 * (i * k + r);
            for (int c = 0; c < 3; c++)
                o[c] = (n[0] * S[0][c] + n[1] * S[1][c] + n[2] * S[2][c]) + (double)s[c];
        }
    }
    Py_END_ALLOW_THREADS
    free(planes);
    for (int i = 0; i < 8; i++)
        PyBuffer_Release(&v[i]);
    Py_RETURN_NONE;
}

/* excess_rows(dirs, flux, normals, rows, out): out[r] += sum_j max(0, n_r.d_j) f_j for
 * each r in rows (see the file's head). */
static PyObject *
excess_rows(PyObject *self, PyObject *args)
{
    PyObject *obj[5];
    if (!PyArg_ParseTuple(args, "OOOOO", &obj[0], &obj[1], &obj[2], &obj[3], &obj[4]))
        return NULL;
    static const char *fmt[5] = {"f", "f", "f", "i", "d"};
    static const int nd[5] = {2, 2, 2, 1, 2};
    static const char *name[5] = {"dirs", "flux", "normals", "rows", "out"};
    Py_buffer v[5];
    int got = 0;
    for (; got < 5; got++)
        if (get_view(obj[got], &v[got], got == 4, fmt[got], nd[got], name[got]) < 0)
            break;
    const char *err = NULL;
    if (got == 5) {
        for (int i = 0; i < 5 && !err; i++)
            if (!contiguous(&v[i]))
                err = "every array: C-contiguous";
    }
    Py_ssize_t m = 0, N = 0, k = 0;
    if (got == 5 && !err) {
        m = v[0].shape[0];
        N = v[2].shape[0];
        k = v[3].shape[0];
        if (v[0].shape[1] != 3 || v[1].shape[0] != m || v[1].shape[1] != 3)
            err = "dirs, flux: (n, 3) float32";
        else if (v[2].shape[1] != 3 || v[4].shape[0] != N || v[4].shape[1] != 3)
            err = "normals (N, 3) float32, out (N, 3) float64";
        else if (N > 2147483647 || !indices_ok((const int *)v[3].buf, k, N))
            err = "rows: normal indices in [0, N)";
    }
    if (got == 5 && err)
        PyErr_SetString(PyExc_ValueError, err);
    float *planes = NULL;
    if (got == 5 && !err) {
        planes = (float *)malloc(sizeof(float) * (size_t)(6 * m + 1));
        if (planes == NULL) {
            PyErr_NoMemory();
            err = "memory";
        }
    }
    if (got < 5 || err) {
        for (int i = 0; i < got; i++)
            PyBuffer_Release(&v[i]);
        return NULL;
    }
    const float *dirs = (const float *)v[0].buf, *flux = (const float *)v[1].buf;
    const float *normals = (const float *)v[2].buf;
    const int *rows = (const int *)v[3].buf;
    double *out = (double *)v[4].buf;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t j = 0; j < m; j++)
        for (int a = 0; a < 3; a++) {
            planes[a * m + j] = dirs[3 * j + a];
            planes[(3 + a) * m + j] = flux[3 * j + a];
        }
    for (Py_ssize_t r = 0; r < k; r++) {
        float s[3];
        row_excess(normals + 3 * (Py_ssize_t)rows[r], planes, planes + m, planes + 2 * m,
                   planes + 3 * m, planes + 4 * m, planes + 5 * m, m, s);
        double *o = out + 3 * (Py_ssize_t)rows[r];
        o[0] += (double)s[0];
        o[1] += (double)s[1];
        o[2] += (double)s[2];
    }
    Py_END_ALLOW_THREADS
    free(planes);
    for (int i = 0; i < 5; i++)
        PyBuffer_Release(&v[i]);
    Py_RETURN_NONE;
}

/* first_pass(mid, scale, luma, omega, Y, coarse, factor, Ymax): see the file's head. */
static PyObject *
first_pass(PyObject *self, PyObject *args)
{
    PyObject *obj[6];
    double scale_d;
    Py_ssize_t f;
    if (!PyArg_ParseTuple(args, "OdOOOOnO", &obj[0], &scale_d, &obj[1], &obj[2], &obj[3],
                          &obj[4], &f, &obj[5]))
        return NULL;
    const int use_coarse = obj[4] != Py_None;
    static const int nd[6] = {3, 1, 2, 2, 1, 3};
    static const char *name[6] = {"mid", "luma", "omega", "Y", "Ymax", "coarse"};
    PyObject *in[6] = {obj[0], obj[1], obj[2], obj[3], obj[5], obj[4]};
    Py_buffer v[6];
    int got = 0;
    for (; got < 5 + use_coarse; got++)
        if (get_view(in[got], &v[got], got == 0 || got >= 3, "f", nd[got], name[got]) < 0)
            break;
    const int want = 5 + use_coarse;
    const char *err = NULL;
    Py_ssize_t h = 0, w = 0, hc = 0, wc = 0;
    if (got == want) {
        for (int i = 0; i < want && !err; i++)
            if (!contiguous(&v[i]))
                err = "every array: C-contiguous";
        h = v[0].shape[0];
        w = v[0].shape[1];
        if (!err && v[0].shape[2] != 3)
            err = "mid: (h, w, 3) float32";
        else if (!err && v[1].shape[0] != 3)
            err = "luma: (3,) float32";
        else if (!err && (v[2].shape[0] != h || v[2].shape[1] != w || v[3].shape[0] != h
                          || v[3].shape[1] != w))
            err = "omega, Y: (h, w) float32, mid's height and width";
        else if (!err && v[4].shape[0] != h)
            err = "Ymax: (h,) float32";
        else if (!err && f < 1)
            err = "factor: at least 1";
        else if (!err && use_coarse) {
            hc = v[5].shape[0];
            wc = v[5].shape[1];
            if (v[5].shape[2] != 3 || hc > h / f || wc > w / f)
                err = "coarse: (hc, wc, 3) float32, hc * factor <= h, wc * factor <= w";
        }
    }
    if (got == want && err)
        PyErr_SetString(PyExc_ValueError, err);
    if (got < want || err) {
        for (int i = 0; i < got; i++)
            PyBuffer_Release(&v[i]);
        return NULL;
    }
    float *mid = (float *)v[0].buf, *Y = (float *)v[3].buf;
    const float *luma = (const float *)v[1].buf, *omega = (const float *)v[2].buf;
    float *coarse = use_coarse ? (float *)v[5].buf : NULL, *Ymax = (float *)v[4].buf;
    const float scale = (float)scale_d;
    double total = 0.0;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t r0 = 0; r0 < h; r0 += f)
        first_pass_band(mid, Y, Ymax, omega, coarse, h, w, hc, wc, f, r0, scale, luma,
                        &total);
    Py_END_ALLOW_THREADS
    for (int i = 0; i < want; i++)
        PyBuffer_Release(&v[i]);
    return PyFloat_FromDouble(total);
}

static PyMethodDef methods[] = {
    {"first_pass", first_pass, METH_VARARGS,
     "first_pass(mid, scale, luma, omega, Y, coarse, factor, Ymax) -> total: the mid copy "
     "scaled, its luminance Y and each row's largest, its coarse block means and sum of "
     "Y omega."},
    {"truth_caps", truth_caps, METH_VARARGS,
     "truth_caps(x, dw, core, core_at, band, band_at, normals, out): the lights' "
     "truth at the normals, by caps (out written)."},
    {"excess_rows", excess_rows, METH_VARARGS,
     "excess_rows(dirs, flux, normals, rows, out): out[r] += sum_j max(0, n_r.d_j) f_j "
     "for each r in rows (out accumulated)."},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_lights",
    "The lights' truth at their normals from the coarse rest, by caps of normals.", 0,
    methods, kernel_slots
};

PyMODINIT_FUNC
PyInit__lights(void)
{
    return PyModuleDef_Init(&module);
}
