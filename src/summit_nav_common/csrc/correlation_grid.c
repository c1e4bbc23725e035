/* The karto correlative matcher's lookup grids (my_summit_mapping.karto.correlative_matcher).
 *
 * snc_stamp_max: the smeared hit grid: flat[c + k] = max(flat[c + k], kernel[k]) for every
 *   hit cell c (flat indices into a grid `width` cells wide) and every offset k of the
 *   (2 half + 1)^2 kernel; the caller keeps the hits `half` cells inside the grid.
 * snc_box_max: the branch and bound's pooled grid: dst[y][x] = max of src over the
 *   extent x extent box whose lower corner is (x, y), cells beyond the grid read 0
 *   (a separable running maximum: rows, then columns). Returns 0, or -1 when its row
 *   buffer cannot be allocated (dst untouched).
 * snc_correlate_sums: the search's responses before scaling: out[a][p] = sum over the n
 *   points of flat[base[a][i] + shift[p]], for A headings (base: each point's cell at that
 *   heading) and P x-y shifts; the caller keeps every index inside the grid (cells_of).
 * Oracles: correlative_matcher._stamp_reference, _box_max_reference and
 *   _correlate_sums_reference (NumPy).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

void snc_stamp_max(uint8_t *flat, const int64_t *hits, int64_t n, const uint8_t *kernel, int64_t half,
                   int64_t width)
{
    const int64_t size = 2 * half + 1;
    for (int64_t i = 0; i < n; ++i) {
        for (int64_t dy = 0; dy < size; ++dy) {
            uint8_t *row = flat + hits[i] + (dy - half) * width - half;
            const uint8_t *k = kernel + dy * size;
            for (int64_t dx = 0; dx < size; ++dx)
                if (k[dx] > row[dx])
                    row[dx] = k[dx];
        }
    }
}

int snc_box_max(const uint8_t *src, int64_t h, int64_t w, int64_t extent, uint8_t *dst)
{
    uint8_t *tmp = (uint8_t *)malloc((size_t)(h * w));
    if (tmp == NULL)
        return -1;
    for (int64_t y = 0; y < h; ++y) {          /* rows: max over src[y][x .. x + extent) */
        const uint8_t *s = src + y * w;
        uint8_t *t = tmp + y * w;
        for (int64_t x = 0; x < w; ++x) {
            int64_t end = x + extent < w ? x + extent : w;
            uint8_t m = 0;
            for (int64_t j = x; j < end; ++j)
                if (s[j] > m)
                    m = s[j];
            t[x] = m;
        }
    }
    memset(dst, 0, (size_t)(h * w));
    for (int64_t y = 0; y < h; ++y) {          /* columns: max over tmp[y .. y + extent)[x] */
        int64_t end = y + extent < h ? y + extent : h;
        uint8_t *d = dst + y * w;
        for (int64_t j = y; j < end; ++j) {
            const uint8_t *t = tmp + j * w;
            for (int64_t x = 0; x < w; ++x)
                if (t[x] > d[x])
                    d[x] = t[x];
        }
    }
    free(tmp);
    return 0;
}

void snc_correlate_sums(const uint8_t *flat, const int64_t *base, int64_t n_angles, int64_t n_points,
                        const int64_t *shift, int64_t n_shifts, int64_t *out)
{
    for (int64_t a = 0; a < n_angles; ++a) {
        const int64_t *b = base + a * n_points;
        for (int64_t p = 0; p < n_shifts; ++p) {
            const uint8_t *f = flat + shift[p];
            int64_t sum = 0;
            for (int64_t i = 0; i < n_points; ++i)
                sum += f[b[i]];
            out[a * n_shifts + p] = sum;
        }
    }
}
