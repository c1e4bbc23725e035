/* global_planner/GlobalPlanner's hot loops: the potential expansion (Dijkstra / A* with the
   simple or quadratic update), the fill around the goal, and the two path makers
   (gradient descent, steepest descent over cells): my_summit_path_planning.global_planner.

   Compiled at build time into libsummit_nav_kernels.so and called through ctypes
   (summit_nav_common.native), so that a move_base with GlobalPlanner loads no numba (LLVM,
   ~60 MB per process). Each function is the C twin of the Python kernel of the same name
   in global_planner.py (_expand, _clear_endpoint, _gradient_path, _grid_path), which stays
   its test oracle: expressions in the Python's order, double precision, libm's hypot (the
   oracle's np.hypot), and -ffp-contract=off, so the results equal the oracle's to the bit.

   Grids are flat, row-major, nx columns by ny rows; cell n is (n % nx, n / nx). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define POT_HIGH 1.0e10                                   /* global_plan.POT_HIGH: unreached */
#define QUAD_A (-0.2301)                                  /* global_planner.QUAD_A, _B, _C */
#define QUAD_B 0.5307
#define QUAD_C 0.7040
#define HEAP_CAPACITY ((int64_t)1 << 14)                  /* global_planner.HEAP_CAPACITY */
#define PATH_CAPACITY 256                                 /* the path makers' first buffer [points] */

static inline double min2(double a, double b) { return b < a ? b : a; }   /* Python's min(a, b) */

/* New potential of cell n from its four neighbours (the potential calculators): _update. */
static double update(const double *pot, const double *cost, int64_t n, int64_t nx, int64_t ny, int quadratic)
{
    int64_t x = n % nx, y = n / nx;
    double left = x > 0 ? pot[n - 1] : POT_HIGH;
    double right = x < nx - 1 ? pot[n + 1] : POT_HIGH;
    double down = y > 0 ? pot[n - nx] : POT_HIGH;
    double up = y < ny - 1 ? pot[n + nx] : POT_HIGH;
    double tc = min2(left, right), ta = min2(down, up), hf = cost[n];
    if (!quadratic)
        return min2(ta, tc) + hf;
    double dc = tc - ta;
    if (dc < 0.0) {
        dc = -dc;
        ta = tc;
    }
    if (dc >= hf)
        return ta + hf;
    double d = dc / hf;
    return ta + hf * (QUAD_A * d * d + QUAD_B * d + QUAD_C);
}

/* A binary min-heap of (key, cell) that doubles when full: _heap_push / _heap_pop. */
typedef struct {
    double *keys;
    int64_t *vals;
    int64_t size, capacity;
} Heap;

static int heap_push(Heap *h, double key, int64_t val)
{
    if (h->size == h->capacity) {
        double *nk = realloc(h->keys, (size_t)(2 * h->capacity) * sizeof(double));
        if (!nk)
            return -1;
        h->keys = nk;
        int64_t *nv = realloc(h->vals, (size_t)(2 * h->capacity) * sizeof(int64_t));
        if (!nv)
            return -1;
        h->vals = nv;
        h->capacity *= 2;
    }
    int64_t i = h->size;
    while (i > 0) {
        int64_t parent = (i - 1) >> 1;
        if (h->keys[parent] <= key)
            break;
        h->keys[i] = h->keys[parent];
        h->vals[i] = h->vals[parent];
        i = parent;
    }
    h->keys[i] = key;
    h->vals[i] = val;
    h->size++;
    return 0;
}

static int64_t heap_pop(Heap *h)
{
    double *keys = h->keys;
    int64_t *vals = h->vals;
    int64_t top = vals[0];
    int64_t size = --h->size;
    double key = keys[size];
    int64_t val = vals[size], i = 0;
    for (;;) {
        int64_t c = 2 * i + 1;
        if (c >= size)
            break;
        if (c + 1 < size && keys[c + 1] < keys[c])
            c++;
        if (keys[c] >= key)
            break;
        keys[i] = keys[c];
        vals[i] = vals[c];
        i = c;
    }
    if (size > 0) {
        keys[i] = key;
        vals[i] = val;
    }
    return top;
}

/* Python's a % b and a // b for b > 0 */
static inline int64_t pymod(int64_t a, int64_t b) { int64_t r = a % b; return r < 0 ? r + b : r; }
static inline int64_t pydiv(int64_t a, int64_t b) { return (a - pymod(a, b)) / b; }

/* _expand: propagate the potential from the seed cells until goal is accepted (goal -1:
   until every reachable cell is). cost (nx*ny) inf = forbidden; pot (nx*ny) filled with
   POT_HIGH, written in place; heuristic: potential per cell of distance to the goal (0:
   Dijkstra). Returns 1 when the goal was accepted, 0 when not, -1 out of memory;
   *accepted: the number of cells accepted. */
int snc_gp_expand(const double *cost, int64_t nx, int64_t ny, const int64_t *seeds, const double *seed_pots,
                  int64_t n_seeds, int64_t goal, double heuristic, int quadratic, double *pot, int64_t *accepted)
{
    int result = 0;
    *accepted = 0;
    uint8_t *closed = calloc((size_t)(nx * ny > 0 ? nx * ny : 1), 1);
    Heap heap = {malloc(HEAP_CAPACITY * sizeof(double)), malloc(HEAP_CAPACITY * sizeof(int64_t)), 0, HEAP_CAPACITY};
    if (!closed || !heap.keys || !heap.vals) {
        result = -1;
        goto done;
    }
    if (goal < 0)
        heuristic = 0.0;  /* no goal: plain Dijkstra */
    int64_t gx = pymod(goal, nx), gy = pydiv(goal, nx);
    for (int64_t k = 0; k < n_seeds; ++k) {
        int64_t s = seeds[k];
        if (seed_pots[k] < pot[s]) {
            pot[s] = seed_pots[k];
            double h = heuristic > 0.0 ? heuristic * hypot((double)(s % nx - gx), (double)(s / nx - gy)) : 0.0;
            if (heap_push(&heap, pot[s] + h, s)) {
                result = -1;
                goto done;
            }
        }
    }
    while (heap.size > 0) {
        int64_t n = heap_pop(&heap);
        if (closed[n])
            continue;  /* an older, higher entry of a cell accepted before */
        closed[n] = 1;
        ++*accepted;
        if (n == goal) {
            result = 1;
            goto done;
        }
        int64_t x = n % nx, y = n / nx;
        for (int k = 0; k < 4; ++k) {
            int64_t m;
            if (k == 0) {
                if (x == 0)
                    continue;
                m = n - 1;
            } else if (k == 1) {
                if (x == nx - 1)
                    continue;
                m = n + 1;
            } else if (k == 2) {
                if (y == 0)
                    continue;
                m = n - nx;
            } else {
                if (y == ny - 1)
                    continue;
                m = n + nx;
            }
            if (closed[m] || !(cost[m] < INFINITY))
                continue;
            double p = update(pot, cost, m, nx, ny, quadratic);
            if (p < pot[m]) {
                pot[m] = p;
                double h = heuristic > 0.0 ? heuristic * hypot((double)(m % nx - gx), (double)(m / nx - gy)) : 0.0;
                if (heap_push(&heap, p + h, m)) {
                    result = -1;
                    goto done;
                }
            }
        }
    }
done:
    free(closed);
    free(heap.keys);
    free(heap.vals);
    return result;
}

/* _clear_endpoint: give the unreached passable cells within half cells of (gx, gy) a
   potential from their neighbours (x-major order, each fill seeing the earlier ones). */
void snc_gp_clear_endpoint(const double *cost, int64_t nx, int64_t ny, double *pot, int64_t gx, int64_t gy,
                           int64_t half, int quadratic)
{
    for (int64_t i = -half; i <= half; ++i)
        for (int64_t j = -half; j <= half; ++j) {
            int64_t x = gx + i, y = gy + j;
            if (x < 0 || y < 0 || x >= nx || y >= ny)
                continue;
            int64_t n = y * nx + x;
            if (pot[n] < POT_HIGH || !(cost[n] < INFINITY))
                continue;
            double p = update(pot, cost, n, nx, ny, quadratic);
            if (p < POT_HIGH)
                pot[n] = p;
        }
}

/* The path makers' growing (M, 2) point buffer: _append. */
typedef struct {
    double *xy;
    int64_t n, capacity;
} Path;

static int append(Path *p, double x, double y)
{
    if (p->n == p->capacity) {
        double *nb = realloc(p->xy, (size_t)(4 * p->capacity) * sizeof(double));
        if (!nb)
            return -1;
        p->xy = nb;
        p->capacity *= 2;
    }
    p->xy[2 * p->n] = x;
    p->xy[2 * p->n + 1] = y;
    p->n++;
    return 0;
}

/* _grad: unit downhill gradient of reached cell n from its reached 4-neighbours (a
   neighbour off the grid counts as unreached). */
static void grad(const double *pot, int64_t nx, int64_t ny, int64_t n, double *gx_out, double *gy_out)
{
    int64_t x = n % nx, y = n / nx;
    double p = pot[n], gx = 0.0, gy = 0.0;
    if (x > 0 && pot[n - 1] < POT_HIGH)
        gx += pot[n - 1] - p;
    if (x < nx - 1 && pot[n + 1] < POT_HIGH)
        gx += p - pot[n + 1];
    if (y > 0 && pot[n - nx] < POT_HIGH)
        gy += pot[n - nx] - p;
    if (y < ny - 1 && pot[n + nx] < POT_HIGH)
        gy += p - pot[n + nx];
    double norm = hypot(gx, gy);
    if (norm > 0.0) {
        *gx_out = gx / norm;
        *gy_out = gy / norm;
    } else {
        *gx_out = 0.0;
        *gy_out = 0.0;
    }
}

/* _lowest_neighbour: the 8-neighbour of (cx, cy) with the lowest potential below its own,
   else (cx, cy). */
static void lowest_neighbour(const double *pot, int64_t nx, int64_t ny, int64_t cx, int64_t cy, int64_t *bx,
                             int64_t *by)
{
    double best = pot[cy * nx + cx];
    *bx = cx;
    *by = cy;
    for (int64_t dy = -1; dy <= 1; ++dy)
        for (int64_t dx = -1; dx <= 1; ++dx) {
            int64_t x = cx + dx, y = cy + dy;
            if ((dx || dy) && 0 <= x && x < nx && 0 <= y && y < ny && pot[y * nx + x] < best) {
                best = pot[y * nx + x];
                *bx = x;
                *by = y;
            }
        }
}

/* The path's points go to *out (malloc'd, (n, 2) doubles; free with snc_free); *ok: 1 when
   the path reached the start. Returns n, or -1 out of memory (*out NULL). */
static int64_t finish(Path *p, int ok_value, int oom, double **out, int *ok)
{
    if (oom) {
        free(p->xy);
        *out = NULL;
        *ok = 0;
        return -1;
    }
    *out = p->xy;
    *ok = ok_value;
    return p->n;
}

/* _gradient_path: descend the potential from (gx, gy) to (sx, sy) [cells, centres at
   integers] in steps of `step` cells along the bilinearly interpolated gradient; a grid
   step to the lowest 8-neighbour where a neighbour is unreached or the path oscillates. */
int64_t snc_gp_gradient_path(const double *pot, int64_t nx, int64_t ny, double sx, double sy, double gx, double gy,
                             double step, int64_t max_cycles, double **out, int *ok)
{
    Path p = {malloc(2 * PATH_CAPACITY * sizeof(double)), 0, PATH_CAPACITY};
    if (!p.xy)
        return finish(&p, 0, 1, out, ok);
    double px = gx, py = gy;
    for (int64_t cycle = 0; cycle < max_cycles; ++cycle) {
        if (fabs(px - sx) < 0.5 && fabs(py - sy) < 0.5)
            return finish(&p, 1, append(&p, sx, sy), out, ok);
        if (append(&p, px, py))
            return finish(&p, 0, 1, out, ok);
        int64_t n = p.n;
        int64_t cx = (int64_t)floor(px + 0.5), cy = (int64_t)floor(py + 0.5);
        if (cx < 1 || cy < 1 || cx > nx - 2 || cy > ny - 2)
            return finish(&p, 0, 0, out, ok);
        int near_unreached = 0;
        for (int64_t dy = -1; dy <= 1; ++dy)
            for (int64_t dx = -1; dx <= 1; ++dx)
                if (pot[(cy + dy) * nx + cx + dx] >= POT_HIGH)
                    near_unreached = 1;
        const double *b = p.xy;
        int oscillating = n > 2 && b[2 * (n - 1)] == b[2 * (n - 3)] && b[2 * (n - 1) + 1] == b[2 * (n - 3) + 1];
        if (near_unreached || oscillating) {
            int64_t bx, by;
            lowest_neighbour(pot, nx, ny, cx, cy, &bx, &by);
            if (bx == cx && by == cy)
                return finish(&p, 0, 0, out, ok);
            px = (double)bx;
            py = (double)by;
            continue;
        }
        /* bilinear interpolation of the four cells' gradients around the point */
        int64_t ix = (int64_t)floor(px), iy = (int64_t)floor(py);
        double fx = px - (double)ix, fy = py - (double)iy;
        int64_t i00 = iy * nx + ix;
        double g00x, g00y, g10x, g10y, g01x, g01y, g11x, g11y;
        grad(pot, nx, ny, i00, &g00x, &g00y);
        grad(pot, nx, ny, i00 + 1, &g10x, &g10y);
        grad(pot, nx, ny, i00 + nx, &g01x, &g01y);
        grad(pot, nx, ny, i00 + nx + 1, &g11x, &g11y);
        double vx = (1 - fy) * ((1 - fx) * g00x + fx * g10x) + fy * ((1 - fx) * g01x + fx * g11x);
        double vy = (1 - fy) * ((1 - fx) * g00y + fx * g10y) + fy * ((1 - fx) * g01y + fx * g11y);
        double norm = hypot(vx, vy);
        if (norm == 0.0)
            return finish(&p, 0, 0, out, ok);
        px += step * vx / norm;
        py += step * vy / norm;
    }
    return finish(&p, 0, 0, out, ok);
}

/* _grid_path: steepest descent over 8-neighbours from cell (gx, gy) to cell (sx, sy); a
   local minimum next to the start cell (a precise-start seed) steps onto the start cell. */
int64_t snc_gp_grid_path(const double *pot, int64_t nx, int64_t ny, int64_t sx, int64_t sy, int64_t gx, int64_t gy,
                         int64_t max_cycles, double **out, int *ok)
{
    Path p = {malloc(2 * PATH_CAPACITY * sizeof(double)), 0, PATH_CAPACITY};
    if (!p.xy)
        return finish(&p, 0, 1, out, ok);
    int64_t x = gx, y = gy;
    if (append(&p, (double)x, (double)y))
        return finish(&p, 0, 1, out, ok);
    for (int64_t cycle = 0; cycle < max_cycles; ++cycle) {
        if (x == sx && y == sy)
            return finish(&p, 1, 0, out, ok);
        int64_t bx, by;
        lowest_neighbour(pot, nx, ny, x, y, &bx, &by);
        if (bx == x && by == y) {
            if (llabs(x - sx) <= 1 && llabs(y - sy) <= 1) {
                bx = sx;
                by = sy;
            } else {
                return finish(&p, 0, 0, out, ok);
            }
        }
        x = bx;
        y = by;
        if (append(&p, (double)x, (double)y))
            return finish(&p, 0, 1, out, ok);
    }
    return finish(&p, 0, 0, out, ok);
}

/* Frees what a kernel returned through an out pointer. */
void snc_free(void *p)
{
    free(p);
}
