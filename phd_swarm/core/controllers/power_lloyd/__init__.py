"""Chen, Dames & Park (2021): the power-diagram Lloyd controllers ``chen_p`` and ``chen_o``.

- :mod:`.controller`: the registered parts, Lloyd on power cells (eq. 13-14);
- :mod:`.cumulative`: the cumulative target density (Gamma-Poisson, eq. 8-11) and the power
  weights it gives (eq. 13-14).
"""
