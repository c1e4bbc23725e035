/* Shortest paths on the 8-connected grid graph of a cost grid (NavFn's potential).

   Compiled ahead of time at build time (catkin's CMakeLists.txt) into
   libsummit_nav_kernels.so and called through ctypes (summit_nav_common.native), so a
   node that needs these loops loads neither numba's LLVM (~60 MB per process) nor SciPy.
   Each function is the C twin of a NumPy/Python reference kept as its test oracle:
   navfn.grid_graph_matrix_reference, navfn.reduced_weights_reference and
   navfn.dijkstra_reference. Floating-point expressions are written in the references'
   order and the file is built with -ffp-contract=off, so the results are equal to the bit.

   Dijkstra (Dijkstra 1959) with a binary heap and lazy deletion: a node is settled when
   first popped and then relaxes its edges with its final distance, so each distance is
   the least d(u) + w(u, v) over settled u, whatever the order ties pop in (the answer of
   scipy.sparse.csgraph.dijkstra, which this replaced). Nodes farther than `limit` are
   never reached (distance +inf), as there. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

static const double SQRT2 = 1.4142135623730951;
/* the eight neighbours in increasing flat index (dy, dx): the order of a CSR row */
static const int ROW_DY[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
static const int ROW_DX[8] = {-1, 0, 1, -1, 1, -1, 0, 1};

/* CSR of the passable cells' graph: row of each passable cell (in flat order) lists its
   passable neighbours in increasing node index, weight = mean cell cost x step length.
   indices/data hold 8 x (number of passable cells); returns the number of edges. */
int64_t snc_grid_csr(const double *cost, const uint8_t *passable, const int64_t *node_of,
                     int64_t h, int64_t w, int64_t *indptr, int32_t *indices, double *data)
{
    int64_t k = 0, node = 0;
    indptr[0] = 0;
    for (int64_t y = 0; y < h; ++y) {
        for (int64_t x = 0; x < w; ++x) {
            if (!passable[y * w + x])
                continue;
            for (int j = 0; j < 8; ++j) {
                int64_t ny = y + ROW_DY[j], nx = x + ROW_DX[j];
                if (ny < 0 || nx < 0 || ny >= h || nx >= w || !passable[ny * w + nx])
                    continue;
                double length = (ROW_DY[j] != 0 && ROW_DX[j] != 0) ? SQRT2 : 1.0;
                indices[k] = (int32_t)node_of[ny * w + nx];
                data[k] = 0.5 * (cost[y * w + x] + cost[ny * w + nx]) * length;
                ++k;
            }
            ++node;
            indptr[node] = k;
        }
    }
    return k;
}

/* A*'s reduced weights w + h(v) - h(u), clipped at 0 (rounding only). */
void snc_reduced_weights(const int64_t *indptr, const int32_t *indices, const double *data,
                         const double *heur, int64_t n, double *out)
{
    for (int64_t u = 0; u < n; ++u) {
        double hu = heur[u];
        for (int64_t j = indptr[u]; j < indptr[u + 1]; ++j) {
            double r = (heur[indices[j]] - hu) + data[j];
            out[j] = r > 0.0 ? r : 0.0;
        }
    }
}

typedef struct { double d; int64_t v; } HeapItem;

static void heap_push(HeapItem *heap, int64_t *size, double d, int64_t v)
{
    int64_t i = (*size)++;
    while (i > 0) {
        int64_t p = (i - 1) / 2;
        if (heap[p].d <= d)
            break;
        heap[i] = heap[p];
        i = p;
    }
    heap[i].d = d;
    heap[i].v = v;
}

static HeapItem heap_pop(HeapItem *heap, int64_t *size)
{
    HeapItem top = heap[0], last = heap[--(*size)];
    int64_t i = 0, n = *size;
    for (;;) {
        int64_t c = 2 * i + 1;
        if (c >= n)
            break;
        if (c + 1 < n && heap[c + 1].d < heap[c].d)
            ++c;
        if (last.d <= heap[c].d)
            break;
        heap[i] = heap[c];
        i = c;
    }
    if (n > 0)
        heap[i] = last;
    return top;
}

/* Distances from node src over the CSR graph into dist (n); +inf where not reached
   within limit. Returns 0, or -1 when out of memory. */
int snc_dijkstra(const int64_t *indptr, const int32_t *indices, const double *data, int64_t n,
                 int64_t src, double limit, double *dist)
{
    /* each relaxation pushes at most once: edges + 1 items */
    int64_t cap = indptr[n] + 1, size = 0;
    HeapItem *heap = malloc((size_t)cap * sizeof(HeapItem));
    uint8_t *settled = calloc((size_t)n, 1);
    if (!heap || !settled) {
        free(heap);
        free(settled);
        return -1;
    }
    for (int64_t i = 0; i < n; ++i)
        dist[i] = INFINITY;
    dist[src] = 0.0;
    heap_push(heap, &size, 0.0, src);
    while (size > 0) {
        HeapItem it = heap_pop(heap, &size);
        int64_t u = it.v;
        if (settled[u] || it.d != dist[u])
            continue;
        settled[u] = 1;
        double du = dist[u];
        for (int64_t j = indptr[u]; j < indptr[u + 1]; ++j) {
            int64_t v = indices[j];
            if (settled[v])
                continue;
            double nd = du + data[j];
            if (nd <= limit && nd < dist[v]) {
                dist[v] = nd;
                heap_push(heap, &size, nd, v);
            }
        }
    }
    /* reached but never settled cannot happen (every pushed node is popped) */
    free(heap);
    free(settled);
    return 0;
}

/* The same Dijkstra on the grid itself, edge weights computed where they are used (no
   CSR matrix: for a 440 x 320 map the matrix and A*'s reduced copy took ~16 MB a plan).
   cost (h x w): cell costs, +inf where forbidden; each cell's 8 neighbours, the weight of
   a step the mean of the two cell costs x its length, as snc_grid_csr writes it; with
   heur (h x w, or NULL) the weights are A*'s reduced ones, (heur[v] - heur[u]) + w
   clipped at 0, as snc_reduced_weights. An indexed binary heap with decrease-key keeps
   the memory at a few bytes a cell; the distances are those of snc_dijkstra (each the
   least d(u) + w(u, v) over settled u). dist (h x w) <- distances from cell src, +inf
   where not reached within limit. Returns 0, or -1 when out of memory. */
int snc_grid_dijkstra(const double *cost, const double *heur, int64_t h, int64_t w, int64_t src,
                      double limit, double *dist)
{
    int64_t n = h * w, size = 0;
    int32_t *heap = malloc((size_t)n * sizeof(int32_t));
    int32_t *pos = malloc((size_t)n * sizeof(int32_t));   /* -1: never queued, -2: settled */
    if (!heap || !pos) {
        free(heap);
        free(pos);
        return -1;
    }
    for (int64_t i = 0; i < n; ++i) {
        dist[i] = INFINITY;
        pos[i] = -1;
    }
#define SIFT_UP(i0) do {                                                      \
        int64_t i_ = (i0); int32_t c_ = heap[i_]; double d_ = dist[c_];       \
        while (i_ > 0) {                                                      \
            int64_t p_ = (i_ - 1) / 2;                                        \
            if (dist[heap[p_]] <= d_) break;                                  \
            heap[i_] = heap[p_]; pos[heap[i_]] = (int32_t)i_; i_ = p_;        \
        }                                                                     \
        heap[i_] = c_; pos[c_] = (int32_t)i_;                                 \
    } while (0)
    dist[src] = 0.0;
    heap[size++] = (int32_t)src;
    pos[src] = 0;
    while (size > 0) {
        int32_t u = heap[0];
        pos[u] = -2;
        int32_t last = heap[--size];
        if (size > 0) {                                /* sift `last` down from the root */
            int64_t i = 0;
            double dl = dist[last];
            for (;;) {
                int64_t c = 2 * i + 1;
                if (c >= size)
                    break;
                if (c + 1 < size && dist[heap[c + 1]] < dist[heap[c]])
                    ++c;
                if (dl <= dist[heap[c]])
                    break;
                heap[i] = heap[c];
                pos[heap[i]] = (int32_t)i;
                i = c;
            }
            heap[i] = last;
            pos[last] = (int32_t)i;
        }
        int64_t y = u / w, x = u % w;
        double du = dist[u], cu = cost[u], hu = heur ? heur[u] : 0.0;
        for (int j = 0; j < 8; ++j) {
            int64_t ny = y + ROW_DY[j], nx = x + ROW_DX[j];
            if (ny < 0 || nx < 0 || ny >= h || nx >= w)
                continue;
            int64_t v = ny * w + nx;
            if (pos[v] == -2 || !isfinite(cost[v]))
                continue;
            double length = (ROW_DY[j] != 0 && ROW_DX[j] != 0) ? SQRT2 : 1.0;
            double wt = 0.5 * (cu + cost[v]) * length;
            if (heur) {
                double r = (heur[v] - hu) + wt;
                wt = r > 0.0 ? r : 0.0;
            }
            double nd = du + wt;
            if (nd <= limit && nd < dist[v]) {
                dist[v] = nd;
                if (pos[v] < 0) {
                    heap[size] = (int32_t)v;
                    SIFT_UP(size);
                    ++size;
                } else {
                    SIFT_UP(pos[v]);
                }
            }
        }
    }
#undef SIFT_UP
    free(heap);
    free(pos);
    return 0;
}
