"""The registry of the kinds scenario files name (sensors, rules, parts, generators): the
floor beneath every other, since the file format and the world's parts both reach it.

``registry``: the ``Kinded`` base and the ``Kinds`` registries (``SENSOR_KINDS``, ...);
``entry_points``: the packages that add kinds through the ``flatland_ma.extensions``
entry-point group.
"""
