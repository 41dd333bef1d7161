"""Run logs on disk: the MCAP writer and reader, and rosbag2's ``metadata.yaml``.

Below the nodes and the tools: the recorder node writes with :mod:`.mcap_log`, and replay,
evaluate and the log check read with it.
"""
