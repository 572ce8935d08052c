"""Bodies and their parts: the ``Part`` kinds (base, head, arm segments, graspers) with
the controls each adds, the body that drives them, and the actuator that derives an
agent's action space from its parts' controls and checks every action."""
