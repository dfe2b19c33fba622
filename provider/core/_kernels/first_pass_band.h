/* The lights' first pass over one band of the mid copy (lights/_lights.c's first_pass, and
 * sh9/_fold.c's fold_lens, which runs it on each band of the copy as its fold completes the
 * band, while the band is still in cache: issue 44).
 *
 * Shipped in the sdist (setup.py's depends, MANIFEST.in): the kernels compile from it. */
#ifndef SHLIGHT_FIRST_PASS_BAND_H
#define SHLIGHT_FIRST_PASS_BAND_H

#include <Python.h>
#include <math.h>

/* Mid rows [r0, min(r0 + f, h)) of the (h, w, 3) copy mid: scaled in place by scale
 * (skipped at 1), their luminance l . rgb into Y and each row's largest Y into Ymax (-inf
 * for a row of none above it: a NaN is never the largest, as it is never above a
 * threshold), Y times omega added to *total (float32 products, a double sum), and where
 * coarse is given and the band is one of its hc rows (r0 / f < hc), the means of its first
 * wc f x f blocks into coarse's row r0 / f. */
static void
first_pass_band(float *mid, float *Y, float *Ymax, const float *omega, float *coarse,
                Py_ssize_t h, Py_ssize_t w, Py_ssize_t hc, Py_ssize_t wc, Py_ssize_t f,
                Py_ssize_t r0, float scale, const float *luma, double *total)
{
    const float l0 = luma[0], l1 = luma[1], l2 = luma[2];
    const float inv = 1.0f / (float)(f * f);
    const Py_ssize_t r1 = r0 + f < h ? r0 + f : h;
    double sum = *total;
    for (Py_ssize_t y = r0; y < r1; y++) {
        float *m = mid + 3 * w * y, *yr = Y + w * y;
        const float *om = omega + w * y;
        if (scale != 1.0f)
            for (Py_ssize_t i = 0; i < 3 * w; i++)
                m[i] *= scale;
        float top = -HUGE_VALF;
        for (Py_ssize_t x = 0; x < w; x++) {
            const float Yx = (l0 * m[3 * x] + l1 * m[3 * x + 1]) + l2 * m[3 * x + 2];
            yr[x] = Yx;
            top = Yx > top ? Yx : top;
            sum += (double)(Yx * om[x]);
        }
        Ymax[y] = top;
    }
    *total = sum;
    if (coarse != NULL && r0 / f < hc) {        /* hc * f <= h: the callers check it */
        float *c = coarse + 3 * wc * (r0 / f);
        for (Py_ssize_t j = 0; j < wc; j++) {
            float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f;
            for (Py_ssize_t y = r0; y < r0 + f; y++) {
                const float *m = mid + 3 * (w * y + f * j);
                for (Py_ssize_t x = 0; x < f; x++) {
                    s0 += m[3 * x];
                    s1 += m[3 * x + 1];
                    s2 += m[3 * x + 2];
                }
            }
            c[3 * j] = s0 * inv;
            c[3 * j + 1] = s1 * inv;
            c[3 * j + 2] = s2 * inv;
        }
    }
}

#endif
