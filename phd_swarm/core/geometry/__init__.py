"""The shared geometry every system stands on: the map and its grid, polygons, partitions.

- :mod:`.grid`: the map E, its square bins and disk fields of view;
- :mod:`.polygons`: convex polygons (areas, clipping);
- :mod:`.ownership`: which robot owns each bin under a power diagram (ties to the lower id);
- :mod:`.partition`: the robots' (power) cells clipped to E, as polygons and bins;
- :mod:`.points`: small point-set helpers.
"""
