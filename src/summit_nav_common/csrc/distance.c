/* Distance transforms of a uint8 grid: distance of each cell to the nearest zero cell.

   snc_edt: the exact Euclidean distance transform (Felzenszwalb & Huttenlocher 2012,
   "Distance Transforms of Sampled Functions": a 1-D pass down each column, then the lower
   envelope of parabolas along each row). It reproduces OpenCV's distanceTransform(DIST_L2,
   DIST_MASK_PRECISE), which the costmaps and DWA used, to the bit: the squared column
   distances are floats, a column without a zero cell counts as 1e15 away, and each
   envelope intersection is computed in float with the reciprocal rounded to float as
   there; the result is the float square root.

   snc_chamfer5_labels: the 5x5 chamfer distance (Borgefors 1986, "Distance
   transformations in digital images") with weights 1, 1.4 and 2.1969 in 16.16 fixed
   point, one forward and one backward raster pass, and for each cell the label of the
   zero cell it took its distance from (zero cells labelled 1, 2, ... in raster order):
   OpenCV's distanceTransformWithLabels(DIST_L2, DIST_MASK_5, DIST_LABEL_PIXEL), which
   DWA's plan-distance field used; the same neighbour order and strict comparisons, so the
   same label wins a tie. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#define EDT_INF 1e15f

/* dist (h x w floats) <- exact Euclidean distance of each cell to the nearest cell whose
   src is 0. Returns 0, or -1 when out of memory. */
int snc_edt(const uint8_t *src, int64_t h, int64_t w, float *dist)
{
    int64_t big = h > w ? h : w;
    float *sq = malloc((size_t)big * sizeof(float));
    float *inv = malloc((size_t)(w + 1) * sizeof(float));
    float *f = malloc((size_t)(w + 1) * sizeof(float));
    float *z = malloc((size_t)(w + 2) * sizeof(float));
    int64_t *v = malloc((size_t)(w + 1) * sizeof(int64_t));
    int64_t *col = malloc((size_t)h * sizeof(int64_t));
    if (!sq || !inv || !f || !z || !v || !col) {
        free(sq); free(inv); free(f); free(z); free(v); free(col);
        return -1;
    }
    for (int64_t i = 0; i < big; ++i)
        sq[i] = (float)(i * i);
    /* columns: squared distance to the nearest zero in the column (EDT_INF: none) */
    for (int64_t x = 0; x < w; ++x) {
        int64_t d = 2 * h;                        /* "none below" */
        for (int64_t y = h - 1; y >= 0; --y) {
            d = src[y * w + x] == 0 ? 0 : d + 1;
            col[y] = d;
        }
        d = 2 * h;                                /* "none above" */
        for (int64_t y = 0; y < h; ++y) {
            d = src[y * w + x] == 0 ? 0 : d + 1;
            if (col[y] < d)
                d = col[y];
            dist[y * w + x] = d < h ? sq[d] : EDT_INF;
            if (d > 2 * h)
                d = 2 * h;                        /* keep it from growing without bound */
        }
    }
    /* rows: lower envelope of the parabolas f[p] + (q - p)^2 */
    inv[0] = 0.0f;
    for (int64_t i = 1; i < w; ++i)
        inv[i] = (float)(0.5 / (double)i);
    for (int64_t y = 0; y < h; ++y) {
        float *d = dist + y * w;
        int64_t k = 0;
        v[0] = 0;
        z[0] = -EDT_INF;
        z[1] = EDT_INF;
        f[0] = d[0];
        for (int64_t q = 1; q < w; ++q) {
            float fq = d[q];
            f[q] = fq;
            for (;; --k) {
                int64_t p = v[k];
                float s = (((fq + sq[q]) - d[p]) - sq[p]) * inv[q - p];
                if (s > z[k]) {
                    ++k;
                    v[k] = q;
                    z[k] = s;
                    z[k + 1] = EDT_INF;
                    break;
                }
            }
        }
        k = 0;
        for (int64_t q = 0; q < w; ++q) {
            while (z[k + 1] < (float)q)
                ++k;
            int64_t p = v[k];
            int64_t a = q > p ? q - p : p - q;
            d[q] = sqrtf(sq[a] + f[p]);
        }
    }
    free(sq); free(inv); free(f); free(z); free(v); free(col);
    return 0;
}

#define CH_SHIFT 16
#define CH_FAR (INT32_MAX >> 2)

/* One chamfer step at a cell: the least of (*best, t[n] + weight[n]) over the 8 mask
   neighbours, in the order given, strict comparisons (the first of equals wins), and the
   label it came from. Off the grid t holds CH_FAR: CH_FAR + weight is never chosen. */
static void chamfer_relax(const int32_t *t, const int64_t *toff, const int64_t *loff, const int32_t *weight,
                          const int32_t *labels, int32_t *best, int32_t *lab)
{
    for (int n = 0; n < 8; ++n) {
        int32_t cand = t[toff[n]] + weight[n];
        if (*best > cand) {
            *best = cand;
            *lab = labels[loff[n]];
        }
    }
}

/* dist (h x w floats), labels (h x w int32) <- the 5x5 chamfer distance to the nearest
   zero cell of src and that cell's label. Returns 0, or -1 when out of memory. */
int snc_chamfer5_labels(const uint8_t *src, int64_t h, int64_t w, float *dist, int32_t *labels)
{
    const int64_t B = 2, stride = w + 2 * B;
    /* the weights as float x 2^16, rounded to nearest (1.0f, 1.4f, 2.1969f) */
    const int32_t a = (int32_t)lrintf(1.0f * (float)(1 << CH_SHIFT));
    const int32_t b = (int32_t)lrintf(1.4f * (float)(1 << CH_SHIFT));
    const int32_t c = (int32_t)lrintf(2.1969f * (float)(1 << CH_SHIFT));
    const float scale = 1.0f / (float)(1 << CH_SHIFT);
    int32_t *buf = malloc((size_t)((h + 2 * B) * stride) * sizeof(int32_t));
    if (!buf)
        return -1;
    int32_t next = 1;
    for (int64_t i = 0; i < h * w; ++i)
        labels[i] = src[i] == 0 ? next++ : 0;
    for (int64_t i = 0; i < (h + 2 * B) * stride; ++i)
        buf[i] = CH_FAR;
    /* the 8 earlier neighbours of the forward pass, (dy, dx, weight), in the order tried */
    const int64_t fdy[8] = {-2, -2, -1, -1, -1, -1, -1, 0};
    const int64_t fdx[8] = {-1, 1, -2, -1, 0, 1, 2, -1};
    const int32_t fw[8] = {c, c, c, b, a, b, c, a};
    int64_t ft[8], fl[8];                         /* offsets in buf and in labels */
    for (int n = 0; n < 8; ++n) {
        ft[n] = fdy[n] * stride + fdx[n];
        fl[n] = fdy[n] * w + fdx[n];
    }
    for (int64_t y = 0; y < h; ++y) {
        int32_t *t = buf + (y + B) * stride + B;
        for (int64_t x = 0; x < w; ++x) {
            if (src[y * w + x] == 0) {
                t[x] = 0;
                continue;
            }
            int32_t best = CH_FAR, lab = 0;
            chamfer_relax(t + x, ft, fl, fw, labels + y * w + x, &best, &lab);
            t[x] = best;
            labels[y * w + x] = lab;
        }
    }
    /* the backward pass mirrors it: later neighbours, nearest-last order */
    const int64_t bdy[8] = {2, 2, 1, 1, 1, 1, 1, 0};
    const int64_t bdx[8] = {1, -1, 2, 1, 0, -1, -2, 1};
    const int32_t bw[8] = {c, c, c, b, a, b, c, a};
    int64_t bt[8], bl[8];
    for (int n = 0; n < 8; ++n) {
        bt[n] = bdy[n] * stride + bdx[n];
        bl[n] = bdy[n] * w + bdx[n];
    }
    for (int64_t y = h - 1; y >= 0; --y) {
        int32_t *t = buf + (y + B) * stride + B;
        for (int64_t x = w - 1; x >= 0; --x) {
            int32_t best = t[x], lab = labels[y * w + x];
            if (best > a) {
                chamfer_relax(t + x, bt, bl, bw, labels + y * w + x, &best, &lab);
                t[x] = best;
                labels[y * w + x] = lab;
            }
            dist[y * w + x] = (float)best * scale;
        }
    }
    free(buf);
    return 0;
}
