/* 8-connected components of the nonzero cells of a uint8 grid (breadth-first search),
   labelled 1, 2, ... in the raster order of each component's first cell; 0 elsewhere.
   What navfn used OpenCV's connectedComponents and floodFill for: which cells are
   joined, not the label numbers. */
#include <stdint.h>
#include <stdlib.h>

int64_t snc_label8(const uint8_t *mask, int64_t h, int64_t w, int32_t *labels)
{
    int64_t *queue = malloc((size_t)(h * w > 0 ? h * w : 1) * sizeof(int64_t));
    if (!queue)
        return -1;
    for (int64_t i = 0; i < h * w; ++i)
        labels[i] = 0;
    int32_t next = 0;
    for (int64_t start = 0; start < h * w; ++start) {
        if (!mask[start] || labels[start])
            continue;
        labels[start] = ++next;
        int64_t head = 0, tail = 0;
        queue[tail++] = start;
        while (head < tail) {
            int64_t c = queue[head++], y = c / w, x = c % w;
            for (int64_t dy = -1; dy <= 1; ++dy) {
                for (int64_t dx = -1; dx <= 1; ++dx) {
                    int64_t ny = y + dy, nx = x + dx;
                    if ((dy || dx) && ny >= 0 && nx >= 0 && ny < h && nx < w) {
                        int64_t q = ny * w + nx;
                        if (mask[q] && !labels[q]) {
                            labels[q] = next;
                            queue[tail++] = q;
                        }
                    }
                }
            }
        }
    }
    free(queue);
    return next;
}
