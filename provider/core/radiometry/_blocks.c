/* An 8-bit frame decoded through its table and averaged over f x f blocks, in one pass.
 *
 * decode_blocks(frame, table, factor, out[, spans])
 *   frame  uint8 (H, W, C) with contiguous pixels (rows may be strided), C <= 4
 *   table  float32, 256 entries (one curve) or 256*C (per channel, entry v*C + c)
 *   factor int f >= 1, at most H and W: out pixel (y, x) is the mean of table[frame] over
 *          rows [y*f, y*f + f) and columns [x*f, x*f + f) (f = 1: the decode alone)
 *   out    float32 (H/f, W/f, C), written; frame rows and columns past H/f*f, W/f*f unread
 *   spans  None, or int32 (H/f, 2): out row y's blocks [spans[y][0], spans[y][1]) only are
 *          read (the blocks a projection gives a weight), the rest of the row written 0
 *
 * Equals cv2.LUT followed by an area resize by an integer factor, to float rounding: each
 * block's f*f samples are summed in float32, in row order. Why C: cv2.LUT costs about six
 * instructions a sample and writes a float copy of the frame that the resize reads again;
 * here a sample costs a byte load and an add from the table (issue 34). No Python object is
 * touched inside the loops, so the GIL is released there. Its Python twin, the same
 * signature, numbers and errors: provider/core/radiometry/blocks.py's _decode_blocks_py. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdlib.h>
#include <string.h>

#include "buffer_check.h"

/* One frame row's sums over groups of f pixels into acc (w pixels of C channels): stored
 * (first row of a block) or added. Inlined with f and C constant in the common cases, so
 * that the compiler unrolls the group: a sample costs a byte load and an add. */
KERNEL_INLINE void
row_sums(const unsigned char *row, const float *t, int shared, Py_ssize_t w, int f, int C,
         int first, float *acc)
{
    for (Py_ssize_t x = 0; x < w; x++) {
        const unsigned char *p = row + x * f * C;
        float *a = acc + x * C;
        for (int c = 0; c < C; c++) {
            float s = shared ? t[p[c]] : t[p[c] * C + c];
            for (int l = 1; l < f; l++)
                s += shared ? t[p[l * C + c]] : t[p[l * C + c] * C + c];
            a[c] = first ? s : a[c] + s;
        }
    }
}

static PyObject *
decode_blocks(PyObject *self, PyObject *args)
{
    PyObject *frame_obj, *table_obj, *out_obj, *spans_obj = Py_None;
    int f;
    Py_buffer fr, tb, out, sp;
    if (!PyArg_ParseTuple(args, "OOiO|O", &frame_obj, &table_obj, &f, &out_obj, &spans_obj))
        return NULL;
    if (f < 1) {
        PyErr_SetString(PyExc_ValueError, "factor must be at least 1");
        return NULL;
    }
    if (get_view(frame_obj, &fr, 0, "B", 3, "frame") < 0)
        return NULL;
    if (fr.shape[0] < f || fr.shape[1] < f) {     /* no block to average: not an empty out */
        PyErr_SetString(PyExc_ValueError,
                        "factor: larger than the frame (H // factor or W // factor is 0)");
        PyBuffer_Release(&fr);
        return NULL;
    }
    if (get_view(table_obj, &tb, 0, "f", 1, "table") < 0) {
        PyBuffer_Release(&fr);
        return NULL;
    }
    if (get_view(out_obj, &out, 1, "f", 3, "out") < 0) {
        PyBuffer_Release(&fr);
        PyBuffer_Release(&tb);
        return NULL;
    }
    const int use_spans = spans_obj != Py_None;
    if (use_spans && get_view(spans_obj, &sp, 0, "i", 2, "spans") < 0) {
        PyBuffer_Release(&fr); PyBuffer_Release(&tb); PyBuffer_Release(&out);
        return NULL;
    }
    Py_ssize_t H = fr.shape[0], W = fr.shape[1], C = fr.shape[2];
    Py_ssize_t h = H / f, w = W / f, n = tb.shape[0];
    const char *err = NULL;
    if (C < 1 || C > 4 || fr.strides[2] != 1 || fr.strides[1] != C)
        err = "frame: pixels must be contiguous, 1 to 4 channels";
    else if (tb.strides[0] != 4 || (n != 256 && n != 256 * C))
        err = "table: 256 contiguous entries, or 256 per channel";
    else if (out.shape[0] != h || out.shape[1] != w || out.shape[2] != C
             || out.strides[2] != 4 || out.strides[1] != 4 * C)
        err = "out: must be (H // factor, W // factor, C) float32 with contiguous pixels";
    else if (use_spans && (sp.shape[0] != h || sp.shape[1] != 2 || sp.strides[1] != 4
                           || sp.strides[0] != 8))
        err = "spans: (H // factor, 2) contiguous int32";
    const int *span = use_spans ? (const int *)sp.buf : NULL;
    for (Py_ssize_t y = 0; !err && use_spans && y < h; y++)
        if (span[2 * y] < 0 || span[2 * y] > span[2 * y + 1] || span[2 * y + 1] > w)
            err = "spans: each row's [first, stop) within [0, W // factor]";
    if (err) {
        PyErr_SetString(PyExc_ValueError, err);
        PyBuffer_Release(&fr); PyBuffer_Release(&tb); PyBuffer_Release(&out);
        if (use_spans)
            PyBuffer_Release(&sp);
        return NULL;
    }
    float *acc = (float *)malloc(sizeof(float) * (size_t)(w * C + 1));
    if (acc == NULL) {
        PyBuffer_Release(&fr); PyBuffer_Release(&tb); PyBuffer_Release(&out);
        if (use_spans)
            PyBuffer_Release(&sp);
        return PyErr_NoMemory();
    }
    const float *t = (const float *)tb.buf;
    const int shared = n == 256;
    const float inv = 1.0f / ((float)f * (float)f);
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t y = 0; y < h; y++) {
        float *o = (float *)((char *)out.buf + y * out.strides[0]);
        const Py_ssize_t a = use_spans ? span[2 * y] : 0, b = use_spans ? span[2 * y + 1] : w;
        const Py_ssize_t n = b - a;
        for (Py_ssize_t i = 0; i < a * C; i++)
            o[i] = 0.0f;
        for (Py_ssize_t i = b * C; i < w * C; i++)
            o[i] = 0.0f;
        float *sums = f == 1 ? o + a * C : acc;   /* f = 1: decoded straight into out */
        for (Py_ssize_t r = y * f; n > 0 && r < y * f + f; r++) {
            const unsigned char *row = (const unsigned char *)fr.buf + r * fr.strides[0]
                                       + a * f * C;
            const int first = r == y * f;
            if (shared && C == 3 && f == 1)
                row_sums(row, t, 1, n, 1, 3, first, sums);
            else if (shared && C == 3 && f == 2)
                row_sums(row, t, 1, n, 2, 3, first, sums);
            else if (shared && C == 3 && f == 4)
                row_sums(row, t, 1, n, 4, 3, first, sums);
            else if (!shared && C == 3)
                row_sums(row, t, 0, n, f, 3, first, sums);
            else
                row_sums(row, t, shared, n, f, (int)C, first, sums);
        }
        if (f > 1)
            for (Py_ssize_t i = 0; i < n * C; i++)
                o[a * C + i] = acc[i] * inv;
    }
    Py_END_ALLOW_THREADS
    free(acc);
    PyBuffer_Release(&fr); PyBuffer_Release(&tb); PyBuffer_Release(&out);
    if (use_spans)
        PyBuffer_Release(&sp);
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"decode_blocks", decode_blocks, METH_VARARGS,
     "decode_blocks(frame, table, factor, out[, spans]): block means of table[frame] into "
     "out."},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_blocks",
    "An 8-bit frame decoded through its table and block-averaged in one pass.", 0, methods,
    kernel_slots
};

PyMODINIT_FUNC
PyInit__blocks(void)
{
    return PyModuleDef_Init(&module);
}
