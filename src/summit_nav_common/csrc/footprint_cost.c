/* base_local_planner's CostmapModel::footprintCost: the footprint's outline, its edges
   rasterized with Bresenham's line (base_local_planner's LineIterator, ends included),
   against the costmap (my_summit_path_planning.footprint_cost).

   Compiled at build time into libsummit_nav_kernels.so and called through ctypes
   (summit_nav_common.native), so that a move_base with TrajectoryPlannerROS or
   CarrotPlanner loads no numba (LLVM, ~60 MB per process). The C twins of the Python
   kernels _outline_cost and _outline_costs in footprint_cost.py, which stay their test
   oracles (integer walks: the same cells and costs). */
#include "footprint_cost.h"

#define LETHAL_OBSTACLE 254   /* cost_values.LETHAL_OBSTACLE */
#define NO_INFORMATION 255    /* cost_values.NO_INFORMATION */

/* Highest cost on the closed outline through the K vertex cells (vx, vy) of the row-major
   uint8 grid data (w columns; every vertex on it); FOOTPRINT_COLLIDES at the first lethal
   or unknown cell. */
double snc_outline_cost(const uint8_t *data, int64_t w, const int64_t *vx, const int64_t *vy, int64_t k_n)
{
    int worst = 0;
    for (int64_t k = 0; k < k_n; ++k) {
        int64_t x0 = vx[k], y0 = vy[k];
        int64_t x1 = vx[(k + 1) % k_n], y1 = vy[(k + 1) % k_n];
        int64_t dx = x1 >= x0 ? x1 - x0 : x0 - x1, dy = y1 >= y0 ? y1 - y0 : y0 - y1;
        int64_t sx = x1 >= x0 ? 1 : -1, sy = y1 >= y0 ? 1 : -1;
        int xmajor = dx >= dy;
        int64_t den = xmajor ? dx : dy, numadd = xmajor ? dy : dx;
        int64_t num = den / 2;   /* den >= 0: Python's den // 2 */
        int64_t x = x0, y = y0;
        for (int64_t i = 0; i <= den; ++i) {
            int cost = data[y * w + x];
            if (cost == LETHAL_OBSTACLE || cost == NO_INFORMATION)
                return FOOTPRINT_COLLIDES;
            if (cost > worst)
                worst = cost;
            num += numadd;
            if (num >= den) {
                num -= den;
                if (xmajor)
                    y += sy;
                else
                    x += sx;
            }
            if (xmajor)
                x += sx;
            else
                y += sy;
        }
    }
    return (double)worst;
}

/* out[m]: snc_outline_cost of pose m's K vertex cells (vx, vy: (M, K) row-major), or
   FOOTPRINT_OFF_MAP where on_map[m] is 0. */
void snc_outline_costs(const uint8_t *data, int64_t w, const int64_t *vx, const int64_t *vy, const uint8_t *on_map,
                       int64_t m_n, int64_t k_n, double *out)
{
    for (int64_t m = 0; m < m_n; ++m)
        out[m] = on_map[m] ? snc_outline_cost(data, w, vx + m * k_n, vy + m * k_n, k_n) : FOOTPRINT_OFF_MAP;
}
