"""The ROS faces of the built-in parts: their wires and their declared outputs.

One module per part (or per family of parts sharing a message type): how the part's core
messages travel in inboxes (a :class:`~phd_swarm.nodes.wire.Wire`) and how the topics it
declares (:class:`phd_swarm.core.outputs.Output`) are built at a step
(:class:`~phd_swarm.nodes.face.Face`). The generic node code never imports them: a part
names its wire and its faces as ``"module:NAME"`` strings.
"""
