"""The physical world: one pymunk space and its entities (walls, obstacles, items, doors),
zones, stepping and the contact log, the channel agents talk on, and the navigation
grid the planners search."""
