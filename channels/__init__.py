"""The radio: links, messages, loss, latency, bandwidth, windows, range and topology.

A leaf package: it knows nothing of neural maps, scenarios or recorders.
"""
