/* Clearing along straight rays on a uint8 grid, without laying every ray's cells out in
   memory first: the costmaps' obstacle layer clears 1081 rays per scan, and the NumPy walk
   (my_summit_path_planning.layers.ray_cells_continuous, this kernel's oracle) held several
   int64 arrays of every cell of every ray at once, move_base's largest transient memory.
   The same samples as the oracle, computed the same way (k / n, then x0 + t dx, floored;
   -ffp-contract=off keeps the multiply and the add separate), so the same cells. */
#include <math.h>
#include <stdint.h>

void snc_fill_rays(uint8_t *grid, int64_t size_x, int64_t size_y, double x0, double y0,
                   const double *x1, const double *y1, int64_t n_rays, double supersample,
                   uint8_t value)
{
    for (int64_t r = 0; r < n_rays; ++r) {
        double dx = x1[r] - x0, dy = y1[r] - y0;
        double major = fabs(dx) > fabs(dy) ? fabs(dx) : fabs(dy);
        if (!isfinite(major))
            continue;  /* the oracle's samples of such a ray are all NaN or off the grid */
        int64_t n = (int64_t)ceil(supersample * major);
        if (n < 1)
            n = 1;
        for (int64_t k = 0; k <= n; ++k) {
            double t = (double)k / (double)n;
            int64_t cx = (int64_t)floor(x0 + t * dx), cy = (int64_t)floor(y0 + t * dy);
            if (cx >= 0 && cy >= 0 && cx < size_x && cy < size_y)
                grid[cy * size_x + cx] = value;
        }
    }
}
