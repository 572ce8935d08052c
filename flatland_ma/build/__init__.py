"""From a checked scenario spec and a random generator to an episode: the layout and its
generators, entities, bodies and their parts, the ground, and the feasibility checks
that every item and agent can be placed and reached."""
