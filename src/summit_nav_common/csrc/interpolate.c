/* Bilinear interpolation of a float grid: at scattered points (remap) and onto a grid k
   times as fine (upsampling).

   snc_remap_bilinear reproduces OpenCV's remap(INTER_LINEAR, BORDER_CONSTANT) with float
   maps, which DWA's footprint clearance used, to the bit: each coordinate is rounded to
   1/32 cell, the four weights are products of the 1-D weights (1 - t, t) at that 1/32
   step, taken in float, and a corner off the grid takes the border value; a point whose
   whole 2x2 block is off the grid gets the border value. Sums run in the order
   top-left, top-right, bottom-left, bottom-right.

   snc_upsample_linear reproduces OpenCV's resize(INTER_LINEAR) of a float grid by an
   integer factor: the source coordinate of a fine cell is (i + 0.5) / k - 0.5, clamped
   to the grid's edge cells (along a row with the weight reset to the edge cell, across
   rows with the weight kept and both rows clamped), each row first, then across. */
#include <math.h>
#include <stdint.h>

#define TAB_BITS 5
#define TAB_SIZE (1 << TAB_BITS)

static int32_t clamp_short(int32_t v)
{
    return v < -32768 ? -32768 : (v > 32767 ? 32767 : v);
}

void snc_remap_bilinear(const float *src, int64_t h, int64_t w, const float *mx, const float *my,
                        int64_t n, float border, float *out)
{
    float tab[TAB_SIZE][2];
    for (int i = 0; i < TAB_SIZE; ++i) {
        float t = (float)i * (1.0f / TAB_SIZE);
        tab[i][0] = 1.0f - t;
        tab[i][1] = t;
    }
    for (int64_t i = 0; i < n; ++i) {
        int32_t X = (int32_t)lrintf(mx[i] * (float)TAB_SIZE);
        int32_t Y = (int32_t)lrintf(my[i] * (float)TAB_SIZE);
        int64_t sx = clamp_short(X >> TAB_BITS), sy = clamp_short(Y >> TAB_BITS);
        int ax = X & (TAB_SIZE - 1), ay = Y & (TAB_SIZE - 1);
        float w0 = tab[ay][0] * tab[ax][0], w1 = tab[ay][0] * tab[ax][1];
        float w2 = tab[ay][1] * tab[ax][0], w3 = tab[ay][1] * tab[ax][1];
        if (sx >= 0 && sy >= 0 && sx < w - 1 && sy < h - 1) {
            const float *s = src + sy * w + sx;
            out[i] = s[0] * w0 + s[1] * w1 + s[w] * w2 + s[w + 1] * w3;
        } else if (sx >= w || sx + 1 < 0 || sy >= h || sy + 1 < 0) {
            out[i] = border;
        } else {
            int inx0 = sx >= 0 && sx < w, inx1 = sx + 1 >= 0 && sx + 1 < w;
            int iny0 = sy >= 0 && sy < h, iny1 = sy + 1 >= 0 && sy + 1 < h;
            float v0 = inx0 && iny0 ? src[sy * w + sx] : border;
            float v1 = inx1 && iny0 ? src[sy * w + sx + 1] : border;
            float v2 = inx0 && iny1 ? src[(sy + 1) * w + sx] : border;
            float v3 = inx1 && iny1 ? src[(sy + 1) * w + sx + 1] : border;
            out[i] = v0 * w0 + v1 * w1 + v2 * w2 + v3 * w3;
        }
    }
}

/* the source cell and weight of fine index i along an axis of n cells, factor k */
static void linear_coord(int64_t i, int64_t n, int64_t k, int64_t *s, float *t)
{
    float f = (float)(((double)i + 0.5) * (1.0 / (double)k) - 0.5);
    int64_t c = (int64_t)floorf(f);
    f -= (float)c;
    if (c < 0) {
        c = 0;
        f = 0.0f;
    }
    if (c >= n - 1) {
        c = n - 1;
        f = 0.0f;
    }
    *s = c;
    *t = f;
}

/* out ((h k) x (w k)) <- src (h x w) upsampled by k. tmp: two rows of w k floats. */
void snc_upsample_linear(const float *src, int64_t h, int64_t w, int64_t k, float *out, float *tmp)
{
    int64_t W = w * k, H = h * k;
    for (int64_t y = 0; y < H; ++y) {
        /* rows: the weight is not reset at the edges, only the rows clamped (as OpenCV) */
        float fy = (float)(((double)y + 0.5) * (1.0 / (double)k) - 0.5);
        int64_t sy = (int64_t)floorf(fy);
        fy -= (float)sy;
        int64_t rows[2] = {sy < 0 ? 0 : (sy > h - 1 ? h - 1 : sy),
                           sy + 1 < 0 ? 0 : (sy + 1 > h - 1 ? h - 1 : sy + 1)};
        for (int r = 0; r < 2; ++r) {
            const float *s = src + rows[r] * w;
            float *d = tmp + r * W;
            for (int64_t x = 0; x < W; ++x) {
                int64_t sx;
                float fx;
                linear_coord(x, w, k, &sx, &fx);
                /* at the last column only that column, as OpenCV's right edge */
                d[x] = sx < w - 1 ? s[sx] * (1.0f - fx) + s[sx + 1] * fx : s[sx] * 1.0f;
            }
        }
        float b0 = 1.0f - fy, b1 = fy;
        for (int64_t x = 0; x < W; ++x)
            out[y * W + x] = tmp[x] * b0 + tmp[W + x] * b1;
    }
}
