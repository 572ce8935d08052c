"""Drawing what happens; it reads the world and never writes it: the top-down view
(``renderer``), each agent's senses as panels (``senses``), the pygame window
(``window``) and videos and stills (``video``)."""
