"""The distributed PHD filter (Dames 2020 Sec. III, Alg. 1-2) as a transport-agnostic protocol.

:mod:`.messages` mirrors the ``phd_swarm_msgs`` definitions as plain values;
:mod:`.robot` is one robot's state machine (messages in, addressed messages out).
"""
