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
   `loop_match_minimum_response_coarse` and its x and y variances stay under the square of
   `loop_match_maximum_variance_coarse` (an ambiguous match, e.g. along a corridor, has a
   wide spread); then a fine match from there that must reach
   `loop_match_minimum_response_fine`.
4. `check_closure` (ours, beyond open_karto): the graph is optimized without and with the
   new loop edge; a closure that moved any node by more than `loop_closure_max_correction`
   [m], or that raised the optimum's chi2 by more than CHI2_BOUND (3 degrees of freedom,
   p = 0.999) times the graph's own chi2 per degree of freedom (at least 1), is taken
   back: the edge is removed and the poses restored.
"""
from collections import deque
from typing import List, Optional, Set, Tuple

import numpy as np

from .optimizer import chi2_per_edge
from .pose_graph import PoseGraph

CHI2_BOUND = 16.27   # chi-square, 3 degrees of freedom, p = 0.999: a loop edge that adds more
                     # to the optimized graph's chi2 contradicts the rest of it [-]


def near_linked(graph: PoseGraph, node_id: int, max_distance: float, positions: np.ndarray) -> Set[int]:
    """Nodes reachable from node_id through edges, every one within max_distance [m] of it;
    positions (N, 2): where the nodes are (PoseGraph.positions)."""
    close = np.hypot(*(positions - positions[node_id]).T) <= max_distance
    seen = {node_id}
    todo = deque([node_id])
    while todo:
        k = todo.popleft()
        for m in graph.neighbours(k):
            if m not in seen and close[m]:
                seen.add(m)
                todo.append(m)
    return seen


def candidate_chain(node_id: int, near: Set[int], max_distance: float, min_chain: int,
                    positions: np.ndarray, start: int = 0) -> Tuple[List[int], int]:
    """The next candidate chain among nodes start .. node_id - 1 (module docstring, step 2):
    (node ids, where to continue the search); ([], node_id) when there is none."""
    close = np.hypot(*(positions[:node_id] - positions[node_id]).T) <= max_distance
    chain: List[int] = []
    for k in range(start, node_id):
        if close[k]:
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
                  max_correction: float, chi2_without: float, chi2_with: float) -> Optional[str]:
    """Why the loop `edge` must be taken back (module docstring, step 4), or None.
    before / after: the poses (N, 3) before and after optimizing with it; chi2_without /
    chi2_with: the graph's chi2 optimized without / with it."""
    moved = float(np.max(np.hypot(*(after[:, :2] - before[:, :2]).T))) if len(after) else 0.0
    if moved > max_correction:
        return (f"it would move a node by {moved:.2f} m (loop_closure_max_correction "
                f"{max_correction:.2f} m)")
    # the graph's own misfit per degree of freedom scales the test: scan-match covariances
    # are optimistic, and a right closure then adds as much per residual as the rest
    dof = 3 * (len(graph.edges) - 1) - 3 * (len(graph.nodes) - 1)
    scale = max(1.0, chi2_without / dof) if dof > 0 else 1.0
    added = chi2_with - chi2_without
    if added > CHI2_BOUND * scale:
        return (f"the graph cannot take it: chi2 {chi2_without:.1f} -> {chi2_with:.1f} "
                f"(bound +{CHI2_BOUND * scale:.1f})")
    return None
