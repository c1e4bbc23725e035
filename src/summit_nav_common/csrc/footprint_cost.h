/* base_local_planner's footprint cost on a uint8 costmap (footprint_cost.c), shared by the
   trajectory planner's kernels (trajectory.c). */
#ifndef SNC_FOOTPRINT_COST_H
#define SNC_FOOTPRINT_COST_H
#include <stdint.h>

#define FOOTPRINT_COLLIDES (-1.0)   /* footprint_cost.COLLIDES: a lethal or unknown cell on the outline */
#define FOOTPRINT_OFF_MAP (-3.0)    /* footprint_cost.OFF_MAP: the centre or a vertex off the costmap */

double snc_outline_cost(const uint8_t *data, int64_t w, const int64_t *vx, const int64_t *vy, int64_t k_n);

#endif
