"""The rules that turn what happened in a step into rewards and endings: one ordered list
of ``Rule`` kinds (``rule``) over the world's contact log, for items, zones, doors,
deliveries, shaping and the episode's end, and the ``Task`` that applies them."""
