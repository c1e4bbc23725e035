/* gmapping's patched occupancy grid and scan matcher: ray tracing into a PatchPool and the
   beam-endpoint score (my_summit_mapping.grid, my_summit_mapping.scan_matcher).

   Compiled ahead of time at build time (catkin's CMakeLists.txt) into
   libsummit_nav_kernels.so and called through ctypes (summit_nav_common.native), so that
   slam_gmapping loads no numba (LLVM, ~60-100 MB per process). Each function is the C twin
   of the loop it replaced; grid.trace_scan / trace_scan_reference and
   scan_matcher.score_reference / optimize_reference stay the test oracles. Expressions
   are written in the Python code's order, in double precision, and stored to the float32
   patches as NumPy stores them (round to nearest); with -ffp-contract=off the results are
   those of the compiled Python to the bit.

   The pool: store[slot][layer][row][col] float32, 2^shift x 2^shift cells per patch
   (grid.PATCH_SHIFT, passed in), layers HITS, VISITS, SUM_X, SUM_Y. A particle's patch
   (py, px) is pool slot slots[offset + (py - py0) * cols + (px - px0)] inside its rows x
   cols box, -1 where none is allocated. Cell (x, y) lies in patch (y >> shift, x >> shift)
   (arithmetic shift: floor for negative cells). */
#include <math.h>
#include <stdint.h>

#define LAYERS 4
#define HITS 0
#define VISITS 1
#define SUM_X 2
#define SUM_Y 3
#define FULLNESS_THRESHOLD 0.1        /* grid.FULLNESS_THRESHOLD */

static inline int64_t cell_index(int64_t shift, int64_t slot, int layer, int64_t r, int64_t c)
{
    return ((((slot * LAYERS + layer) << shift) + r) << shift) + c;
}

/* Python's a // b for b > 0 */
static inline int64_t floordiv(int64_t a, int64_t b)
{
    int64_t q = a / b;
    return (a % b != 0 && a < 0) ? q - 1 : q;
}

/* Coordinate of step k of n on the Bresenham line start -> start + d (grid.bresenham_cells'
   rounding: floor((2 k d + n) / (2 n))). */
static inline int64_t line_cell(int64_t start, int64_t d, int64_t n, int64_t k)
{
    return n == 0 ? start : start + floordiv(2 * k * d + n, 2 * n);
}

static inline int64_t max64(int64_t a, int64_t b) { return a > b ? a : b; }
static inline int64_t abs64(int64_t a) { return a < 0 ? -a : a; }

/* Marks mark[(py - py0) * cols + (px - px0)] = 1 for every patch the lines from start (2)
   to end_cells (b, 2) pass (cells as [x, y]). */
void snc_touched_patches(int64_t shift, const int64_t *start, const int64_t *end_cells, int64_t b,
                         int64_t py0, int64_t px0, int64_t cols, uint8_t *mark)
{
    for (int64_t i = 0; i < b; ++i) {
        int64_t dx = end_cells[2 * i] - start[0], dy = end_cells[2 * i + 1] - start[1];
        int64_t n = max64(abs64(dx), abs64(dy));
        for (int64_t k = 0; k <= n; ++k) {
            int64_t x = line_cell(start[0], dx, n, k), y = line_cell(start[1], dy, n, k);
            mark[((y >> shift) - py0) * cols + (x >> shift) - px0] = 1;
        }
    }
}

/* Halves a whole patch when one more visit would pass count_limit (keeps frequencies and
   mean hit points, grid.COUNT_LIMIT). */
static inline void guard_limit(float *store, int64_t shift, int64_t slot, int64_t r, int64_t c,
                               double count_limit)
{
    if ((double)store[cell_index(shift, slot, VISITS, r, c)] + 1.0 > count_limit) {
        float *p = store + cell_index(shift, slot, 0, 0, 0);
        for (int64_t j = 0; j < (LAYERS << shift << shift); ++j)
            p[j] = (float)((double)p[j] * 0.5);
    }
}

static inline void add_to(float *store, int64_t shift, int64_t slot, int layer, int64_t r, int64_t c,
                          double v)
{
    float *p = store + cell_index(shift, slot, layer, r, c);
    *p = (float)((double)*p + v);
}

static inline void add_hit(float *store, int64_t shift, int64_t slot, int64_t r, int64_t c, int64_t x,
                           int64_t y, double ex, double ey, double resolution)
{
    add_to(store, shift, slot, HITS, r, c, 1.0);
    add_to(store, shift, slot, SUM_X, r, c, ex - (double)x * resolution);
    add_to(store, shift, slot, SUM_Y, r, c, ey - (double)y * resolution);
}

/* grid.PatchGrid.integrate_scan: every beam's Bresenham line from start to its end cell;
   each cell a visit, the end cell of a returned beam (is_hit) also a hit and its end point
   (ends, [m]); a beam cut at maxUrange leaves its end cell alone. Every patch the lines
   pass must be in the table (slots) and writable. */
void snc_trace_into(float *store, int64_t shift, const int64_t *slots, int64_t py0, int64_t px0, int64_t cols,
                    const int64_t *start, const int64_t *end_cells, const double *ends,
                    const uint8_t *is_hit, int64_t b, double resolution, double count_limit)
{
    int64_t mask = ((int64_t)1 << shift) - 1;
    for (int64_t i = 0; i < b; ++i) {
        int64_t dx = end_cells[2 * i] - start[0], dy = end_cells[2 * i + 1] - start[1];
        int64_t n = max64(abs64(dx), abs64(dy));
        int64_t last = is_hit[i] ? n : n - 1;
        for (int64_t k = 0; k <= last; ++k) {
            int64_t x = line_cell(start[0], dx, n, k), y = line_cell(start[1], dy, n, k);
            int64_t slot = slots[((y >> shift) - py0) * cols + (x >> shift) - px0];
            int64_t r = y & mask, c = x & mask;
            guard_limit(store, shift, slot, r, c, count_limit);
            add_to(store, shift, slot, VISITS, r, c, 1.0);
            if (k == n)
                add_hit(store, shift, slot, r, c, x, y, ends[2 * i], ends[2 * i + 1], resolution);
        }
    }
}

/* grid.PatchGrid.add_hits: a hit, a visit and the end point in each end cell (b, 2). */
void snc_add_hits_into(float *store, int64_t shift, const int64_t *slots, int64_t py0, int64_t px0,
                       int64_t cols, const int64_t *cells, const double *ends, int64_t b, double resolution,
                       double count_limit)
{
    int64_t mask = ((int64_t)1 << shift) - 1;
    for (int64_t i = 0; i < b; ++i) {
        int64_t x = cells[2 * i], y = cells[2 * i + 1];
        int64_t slot = slots[((y >> shift) - py0) * cols + (x >> shift) - px0];
        int64_t r = y & mask, c = x & mask;
        guard_limit(store, shift, slot, r, c, count_limit);
        add_to(store, shift, slot, VISITS, r, c, 1.0);
        add_hit(store, shift, slot, r, c, x, y, ends[2 * i], ends[2 * i + 1], resolution);
    }
}

/* The maps of the particles: MapTables. */
typedef struct {
    const float *store;
    int64_t shift;
    const int64_t *py0, *px0, *rows, *cols, *offset, *slots;
} Maps;

/* scan_matcher's score and log-likelihood of particle i's map at base pose (3): for every
   beam (bx, by in the laser frame [m]) the nearest mean hit point of an occupied cell
   within +-kernel cells of its end point. */
static void beam_sums(const Maps *m, int64_t i, const double *pose, const double *laser,
                      const double *bx, const double *by, int64_t nb, double res, double sigma,
                      double lsigma, int64_t kernel, double null_loglik, double *score_out,
                      double *loglik_out)
{
    double c = cos(pose[2]), s = sin(pose[2]);
    double lx = pose[0] + c * laser[0] - s * laser[1];
    double ly = pose[1] + s * laser[0] + c * laser[1];
    double lt = pose[2] + laser[2];
    double cl = cos(lt), sl = sin(lt);
    double score = 0.0, loglik = 0.0;
    int64_t rows = m->rows[i], cols = m->cols[i], py0 = m->py0[i], px0 = m->px0[i];
    int64_t shift = m->shift, mask = ((int64_t)1 << shift) - 1;
    const int64_t *slots = m->slots + m->offset[i];
    for (int64_t k = 0; k < nb; ++k) {
        double ex = lx + cl * bx[k] - sl * by[k];
        double ey = ly + sl * bx[k] + cl * by[k];
        int64_t ix = (int64_t)floor(ex / res), iy = (int64_t)floor(ey / res);
        double best = -1.0;
        for (int64_t dy = -kernel; dy <= kernel; ++dy) {
            int64_t cy = iy + dy, ty = (cy >> shift) - py0;
            if (ty < 0 || ty >= rows)
                continue;
            for (int64_t dx = -kernel; dx <= kernel; ++dx) {
                int64_t cx = ix + dx, tx = (cx >> shift) - px0;
                if (tx < 0 || tx >= cols)
                    continue;
                int64_t slot = slots[ty * cols + tx];
                if (slot < 0)
                    continue;
                int64_t r = cy & mask, q = cx & mask;
                double hits = m->store[cell_index(shift, slot, HITS, r, q)];
                double visits = m->store[cell_index(shift, slot, VISITS, r, q)];
                if (visits > 0.0 && hits > FULLNESS_THRESHOLD * visits) {
                    double mx = (double)cx * res + (double)m->store[cell_index(shift, slot, SUM_X, r, q)] / hits - ex;
                    double my = (double)cy * res + (double)m->store[cell_index(shift, slot, SUM_Y, r, q)] / hits - ey;
                    double d2 = mx * mx + my * my;
                    if (best < 0.0 || d2 < best)
                        best = d2;
                }
            }
        }
        if (best >= 0.0) {
            score += exp(-best / sigma);
            loglik += -best / lsigma;
        } else {
            loglik += null_loglik;
        }
    }
    *score_out = score;
    *loglik_out = loglik;
}

/* gmapping's ScanMatcher::optimize (hill climbing) of every particle i from init (n, 3):
   poses into out (n, 3), best scores into best_scores (n); moves (n_moves, 3). */
void snc_optimize(const float *store, int64_t shift, const int64_t *py0, const int64_t *px0, const int64_t *rows,
                  const int64_t *cols, const int64_t *offset, const int64_t *slots, const double *init,
                  int64_t n, const double *laser, const double *bx, const double *by, int64_t nb,
                  double res, double sigma, int64_t kernel, double lstep, double astep,
                  int64_t iterations, const double *moves, int64_t n_moves, int64_t max_rounds,
                  double *out, double *best_scores)
{
    Maps m = {store, shift, py0, px0, rows, cols, offset, slots};
    for (int64_t i = 0; i < n; ++i) {
        double current[3] = {init[3 * i], init[3 * i + 1], init[3 * i + 2]};
        double current_score, best_score = -1.0, unused;
        beam_sums(&m, i, current, laser, bx, by, nb, res, sigma, 1.0, kernel, 0.0, &current_score, &unused);
        double ldelta = lstep, adelta = astep;
        int64_t refinement = 0;
        for (int64_t round = 0; round < max_rounds; ++round) {
            if (best_score >= current_score) {
                ++refinement;
                ldelta *= 0.5;
                adelta *= 0.5;
            }
            best_score = current_score;
            double best_local[3] = {current[0], current[1], current[2]};
            for (int64_t j = 0; j < n_moves; ++j) {
                double local[3] = {current[0] + moves[3 * j] * ldelta, current[1] + moves[3 * j + 1] * ldelta,
                                   current[2] + moves[3 * j + 2] * adelta};
                double local_score;
                beam_sums(&m, i, local, laser, bx, by, nb, res, sigma, 1.0, kernel, 0.0, &local_score, &unused);
                if (local_score > current_score) {
                    current_score = local_score;
                    best_local[0] = local[0];
                    best_local[1] = local[1];
                    best_local[2] = local[2];
                }
            }
            current[0] = best_local[0];
            current[1] = best_local[1];
            current[2] = best_local[2];
            if (!(current_score > best_score || refinement < iterations))
                break;
        }
        out[3 * i] = current[0];
        out[3 * i + 1] = current[1];
        out[3 * i + 2] = atan2(sin(current[2]), cos(current[2]));
        best_scores[i] = best_score;
    }
}

/* gmapping's likelihoodAndScore of particle i at poses[i] (n, 3) in its own map. */
void snc_likelihoods(const float *store, int64_t shift, const int64_t *py0, const int64_t *px0, const int64_t *rows,
                     const int64_t *cols, const int64_t *offset, const int64_t *slots, const double *poses,
                     int64_t n, const double *laser, const double *bx, const double *by, int64_t nb,
                     double res, double sigma, double lsigma, int64_t kernel, double null_loglik,
                     double *logliks, double *scores)
{
    Maps m = {store, shift, py0, px0, rows, cols, offset, slots};
    for (int64_t i = 0; i < n; ++i)
        beam_sums(&m, i, poses + 3 * i, laser, bx, by, nb, res, sigma, lsigma, kernel, null_loglik,
                  &scores[i], &logliks[i]);
}
