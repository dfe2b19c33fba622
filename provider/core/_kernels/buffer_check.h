/* What the C kernels share (radiometry/_blocks.c, sh9/_fold.c, sh9/_equirect.c,
 * lights/_lights.c): the check of each array argument and of its contiguity, the
 * portability macros, and the module's declared use of the GIL.
 *
 * Shipped in the sdist (setup.py's depends, MANIFEST.in): the kernels compile from it. */
#ifndef SHLIGHT_BUFFER_CHECK_H
#define SHLIGHT_BUFFER_CHECK_H

#include <Python.h>
#include <string.h>

/* Inlined with constant arguments, so that the compiler unrolls the inner loops. */
#if defined(__GNUC__) || defined(__clang__)
#define KERNEL_INLINE static inline __attribute__((always_inline))
#elif defined(_MSC_VER)
#define KERNEL_INLINE static __forceinline
#else
#define KERNEL_INLINE static inline
#endif

/* MSVC spells C99's restrict __restrict. */
#if defined(_MSC_VER) && !defined(__clang__) && !defined(restrict)
#define restrict __restrict
#endif

/* GCC's and Clang's 4-float vector extension (SSE on x86-64, NEON on 64-bit ARM); other
 * compilers (MSVC), or SHLIGHT_SCALAR_KERNELS defined, take the portable scalar loops. */
#if (defined(__GNUC__) || defined(__clang__)) && !defined(SHLIGHT_SCALAR_KERNELS)
#define KERNEL_VECTOR 1
#else
#define KERNEL_VECTOR 0
#endif

/* obj's buffer as an ndim-d array of struct format fmt ("B", "f", "d", or "i": int32),
 * writable if asked; else ValueError "<name>: expected a <ndim>-d array of format '<fmt>'".
 * The Python twins (blocks.py, fold_twin.py) raise the same. */
static int
get_view(PyObject *obj, Py_buffer *view, int writable, const char *fmt, int ndim,
         const char *name)
{
    int flags = PyBUF_RECORDS_RO | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0)
        return -1;
    /* int32 arrays: numpy says "i", or "l" where a long is 4 bytes (Windows) */
    const int int32 = strcmp(fmt, "i") == 0 && view->format != NULL && view->itemsize == 4
                      && (strcmp(view->format, "i") == 0 || strcmp(view->format, "l") == 0);
    if (view->ndim != ndim || view->format == NULL
            || (!int32 && strcmp(view->format, fmt) != 0)) {
        PyErr_Format(PyExc_ValueError, "%s: expected a %d-d array of format '%s'", name, ndim,
                     fmt);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

/* C-contiguous, dimensions of length 0 or 1 aside (inline: a kernel that takes none of
 * its arrays whole does not warn of it unused). */
static inline int
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

/* The kernels keep no state and touch no Python object while their loops run (the GIL is
 * released there): safe without the GIL (free-threaded CPython 3.13+) and in every
 * sub-interpreter. The caller owns the arrays, as with any numpy function. */
static PyModuleDef_Slot kernel_slots[] = {
#ifdef Py_mod_multiple_interpreters
    {Py_mod_multiple_interpreters, Py_MOD_PER_INTERPRETER_GIL_SUPPORTED},
#endif
#ifdef Py_mod_gil
    {Py_mod_gil, Py_MOD_GIL_NOT_USED},
#endif
    {0, NULL}
};

#endif
