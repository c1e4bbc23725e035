"""Loop-closure candidates, their validation by chain matching, and the check of a closure.

Reference: open_karto's MapperGraph (TryCloseLoop, FindPossibleLoopClosure,
GetNearLinkedScans, FindNearChains) as documented, on Konolige et al. 2010 ("Efficient
Sparse Pose Adjustment for 2D Mapping"); Olson 2009 for the matcher.

1. `near_linked`: the nodes reachable from the current one through graph edges without
   leaving a radius around it: the recent chain and whatever is already tied to it.
2. `candidate_chain`: walking the nodes in order, runs of consecutive nodes within
   `loop_search_maximum_distance` of the current node that are not near-linked; a run
   (a chain) of at least `loop_match_minimum_chain_size` nodes is a candidate.
3. `match_chain` (in the mapper): a coarse match of the current scan against the chain's
   points over the loop search window; accepted when its response reaches
   `loop_match_minimum_response_coarse` and its x and y variances stay under
   `loop_match_maximum_variance_coarse` (an ambiguous match, e.g. along a corridor, has a
   wide spread); then a fine match from there that must reach
   `loop_match_minimum_response_fine`.
4. `check_closure` (ours, beyond open_karto): after optimizing with the new loop edge, a
   closure that moved any node by more than `loop_closure_max_correction` [m], or whose
   edge still disagrees with the optimized poses by more than CHI2_BOUND (Mahalanobis,
   3 degrees of freedom), is taken back: the edge is removed and the poses restored.
"""
from collections import deque
from typing import List, Optional, Set, Tuple

import numpy as np

from .optimizer import chi2_per_edge
from .pose_graph import PoseGraph

CHI2_BOUND = 16.27   # chi-square, 3 degrees of freedom, p = 0.999: a loop edge above this
                     # after optimization contradicts the rest of the graph [-]


def near_linked(graph: PoseGraph, node_id: int, max_distance: float, use_barycenter: bool) -> Set[int]:
    """Nodes reachable from node_id through edges, every one within max_distance [m] of it."""
    origin = graph.nodes[node_id].position(use_barycenter)
    seen = {node_id}
    todo = deque([node_id])
    while todo:
        k = todo.popleft()
        for m in graph.neighbours(k):
            if m in seen:
                continue
            if np.hypot(*(graph.nodes[m].position(use_barycenter) - origin)) <= max_distance:
                seen.add(m)
                todo.append(m)
    return seen


def candidate_chain(graph: PoseGraph, node_id: int, near: Set[int], max_distance: float,
                    min_chain: int, use_barycenter: bool, start: int = 0) -> Tuple[List[int], int]:
    """The next candidate chain among nodes start .. node_id - 1 (module docstring, step 2):
    (node ids, where to continue the search); ([], node_id) when there is none."""
    origin = graph.nodes[node_id].position(use_barycenter)
    chain: List[int] = []
    for k in range(start, node_id):
        close = np.hypot(*(graph.nodes[k].position(use_barycenter) - origin)) <= max_distance
        if close:
            if k in near:
                chain = []
            else:
                chain.append(k)
        else:
            if len(chain) >= min_chain:
                return chain, k + 1
            chain = []
    if len(chain) >= min_chain:
        return chain, node_id
    return [], node_id


def closest_node(graph: PoseGraph, ids: List[int], pose: np.ndarray) -> int:
    """The node of ids nearest to pose's position."""
    d = [np.hypot(*(graph.nodes[k].pose[:2] - pose[:2])) for k in ids]
    return ids[int(np.argmin(d))]


def check_closure(graph: PoseGraph, edge, before: np.ndarray, after: np.ndarray,
                  max_correction: float) -> Optional[str]:
    """Why the loop `edge` must be taken back (module docstring, step 4), or None.
    before / after: the poses (N, 3) before and after optimizing with it."""
    moved = float(np.max(np.hypot(*(after[:, :2] - before[:, :2]).T))) if len(after) else 0.0
    if moved > max_correction:
        return (f"it would move a node by {moved:.2f} m (loop_closure_max_correction "
                f"{max_correction:.2f} m)")
    chi2 = float(chi2_per_edge(after, np.array([edge.i]), np.array([edge.j]), edge.measurement[None, :],
                               edge.information[None, :, :])[0])
    if chi2 > CHI2_BOUND:
        return f"its edge disagrees with the optimized graph (chi2 {chi2:.1f} > {CHI2_BOUND})"
    return None
