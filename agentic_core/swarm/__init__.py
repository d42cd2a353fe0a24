"""The swarm (the paper's Integration Layer): UAVs as A2A agents that sign what they say (:mod:`.signing`), serve
an Agent Card with their state (:mod:`.card`, :mod:`.a2a_server`), call each other (:mod:`.a2a_client`), allocate
tasks by Contract Net, deconflict their legs and fuse what they see.

The A2A modules need the ``a2a`` extra; the rest runs on the base dependencies. Import the modules themselves:
this package imports nothing, so the pure parts never pull in the A2A stack.

>>> import agentic_core.swarm.signing as signing
>>> signing.MAX_AGE_S
30.0
"""
