"""``flatland-ma bench``: what the envs, their sensors and the batched env at scale cost,
each beside the bare physics of the same world, with the machine's load noted.

``throughput``: each env beside its world's bare ``space.step``; ``scale``: the batched
env from 1 to 1,024 worlds and PPO end to end; ``targets``: ``scale``'s other rows
(``make_vec``, a busy core, rays per second); ``breakdown``: where a batched world-step
goes; ``sensors``: each kind of sensor's cost per agent-step; ``load``: what other
processes did to the machine during each row. The command itself is ``flatland_ma.cli.bench``.
"""
