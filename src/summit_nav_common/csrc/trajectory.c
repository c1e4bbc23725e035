/* base_local_planner/TrajectoryPlannerROS's hot loops: MapGrid's breadth-first distance
   wave and generateTrajectory's point-by-point checks of every sampled trajectory
   (my_summit_path_planning.trajectory_planner).

   Compiled at build time into libsummit_nav_kernels.so and called through ctypes
   (summit_nav_common.native), so that a move_base with TrajectoryPlannerROS loads no numba
   (LLVM, ~60 MB per process). The C twins of the Python kernels _wavefront and
   _first_failure in trajectory_planner.py, which stay their test oracles: the same queue
   order and comparisons, so the same distances and first failures to the bit. */
#include <stdlib.h>

#include "footprint_cost.h"

#define NO_WAY (-2.0)   /* trajectory_planner.NO_WAY: no clear way to the plan from a point */

/* _wavefront: the breadth-first wave over blocked (h, w) from the target cells (tx, ty)
   (on the grid), into dist (h, w): 0 on the targets, +1 per 4-connected step over free
   cells, `obstacle` on a blocked cell the wave touches (it stops there), obstacle + 1 on
   cells never touched. Returns 0, or -1 out of memory. */
int snc_tp_wavefront(const uint8_t *blocked, int64_t h, int64_t w, const int64_t *tx, const int64_t *ty,
                     int64_t n_targets, double obstacle, double *dist)
{
    uint8_t *marked = calloc((size_t)(h * w > 0 ? h * w : 1), 1);
    int64_t *queue = malloc((size_t)(h * w + n_targets > 0 ? h * w + n_targets : 1) * sizeof(int64_t));
    if (!marked || !queue) {
        free(marked);
        free(queue);
        return -1;
    }
    for (int64_t i = 0; i < h * w; ++i)
        dist[i] = obstacle + 1.0;
    int64_t head = 0, tail = 0;
    for (int64_t k = 0; k < n_targets; ++k) {
        int64_t c = ty[k] * w + tx[k];
        dist[c] = 0.0;
        marked[c] = 1;
        queue[tail++] = c;
    }
    while (head < tail) {
        int64_t cx = queue[head] % w, cy = queue[head] / w;
        head++;
        double d = dist[cy * w + cx] + 1.0;
        for (int j = 0; j < 4; ++j) {
            int64_t nx = j == 0 ? cx - 1 : j == 1 ? cx + 1 : cx;
            int64_t ny = j == 2 ? cy - 1 : j == 3 ? cy + 1 : cy;
            if (nx < 0 || ny < 0 || nx >= w || ny >= h || marked[ny * w + nx])
                continue;
            int64_t c = ny * w + nx;
            marked[c] = 1;
            if (blocked[c]) {
                dist[c] = obstacle;
                continue;
            }
            dist[c] = d;
            queue[tail++] = c;
        }
    }
    free(marked);
    free(queue);
    return 0;
}

/* _first_failure: each of the N trajectories' points in order, until the first that fails.
   n (N): points of each; on_map (N, S): the centre and every footprint vertex on the
   costmap; vx, vy (N, S, K): the vertex cells; no_way (N, S); centre (N, S): the centre
   cell's cost. Writes first (N): the failing point's index, or n if none; fail (N):
   FOOTPRINT_COLLIDES or NO_WAY (0 if none); occ (N): the highest max(outline cost, centre
   cost) before it. data: the costmap, w columns. */
void snc_tp_first_failure(const uint8_t *data, int64_t w, const int64_t *n, int64_t n_traj, int64_t s_n, int64_t k_n,
                          const uint8_t *on_map, const int64_t *vx, const int64_t *vy, const uint8_t *no_way,
                          const double *centre, int64_t *first, double *fail, double *occ)
{
    for (int64_t i = 0; i < n_traj; ++i) {
        first[i] = n[i];
        fail[i] = 0.0;
        occ[i] = 0.0;
        for (int64_t j = 0; j < n[i]; ++j) {
            int64_t p = i * s_n + j;
            double fp = on_map[p] ? snc_outline_cost(data, w, vx + p * k_n, vy + p * k_n, k_n) : FOOTPRINT_OFF_MAP;
            if (fp < 0) {
                first[i] = j;
                fail[i] = FOOTPRINT_COLLIDES;
                break;
            }
            if (no_way[p]) {
                first[i] = j;
                fail[i] = NO_WAY;
                break;
            }
            /* Python's max(occ, fp, centre): the first of equal values, a later one only when greater */
            double m = occ[i];
            if (fp > m)
                m = fp;
            if (centre[p] > m)
                m = centre[p];
            occ[i] = m;
        }
    }
}
