"""Papaioannou et al.'s agent controller (``sat_search_track``) and the parts only it uses.

- :mod:`.controller`: the registered part, search by plans and track by the Renyi reward,
  and the overlap resolution (Sec. V-B, V-C);
- :mod:`.agent_moves`: the admissible moves (eq. 4);
- :mod:`.search_plan`: the search plans (problem P1's heuristic, Alg. 1);
- :mod:`.renyi` and :mod:`.tracking`: the tracking reward (eq. 8, 17-18) and its choice;
- :mod:`.tracking_overlap`: the test for agents tracking the same targets (eq. 19).
"""
