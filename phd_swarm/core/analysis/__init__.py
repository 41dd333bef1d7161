"""Exact analyses of the systems' models (pure numpy/scipy, no ROS).

- :mod:`.renewal_exact`: meeting times of robots on the DTDS random walk of Shirsat & Berman
  (Sec. III-IV): Kac's mean inter-arrival times, first-meeting distributions on the
  composite chain (eq. 7-8), and seeded simulations to check them.
"""
