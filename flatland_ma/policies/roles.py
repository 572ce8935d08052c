"""A network for each role, in one module: the layers of ``PPONetwork(roles=R)``.

Agents whose observations differ share one padded observation whose one-hot ``role`` entry
names the row's role (``flatland_ma.envs.padding``). With ``roles`` each role has encoders
and a fully connected layer of its own, and every row is read by each role's; the row's
own role's features are kept and the others' set to 0 before the heads, which read

    h = [role_0 * h_0, ..., role_{R-1} * h_{R-1}, role]

(``role`` the one-hot itself, so that each role has its own bias; the heads have none).
A row's logits and value therefore depend on its own role's parameters alone, and its
gradients reach no other role's: a role's network learns from its own agents' steps and
is left as it is by another role's, as though the roles had a network each (non-shared
parameters, as in MAPPO's and BenchMARL's option). Each role's encoders run on every
row, so a step costs R times a shared network's.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import torch
from torch import nn

from flatland_ma.envs.padding import ROLE


class RoleStack(nn.Module):
    """One entry's encoders, one per role, each reading every row; their encodings joined
    along the features, role after role."""

    def __init__(self, encoders: Sequence[nn.Module]):
        super().__init__()
        self.encoders = nn.ModuleList(encoders)
        self.sizes = [int(encoder.features) for encoder in encoders]  # type: ignore[arg-type]
        self.features = sum(self.sizes)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.cat([encoder(x) for encoder in self.encoders], dim=1)


class RoleBody(nn.Module):
    """Each role's fully connected layer (``hidden`` units, ReLU) over its own encodings
    of the entries ``stacks`` (entry -> its ``RoleStack``), masked by the rows' roles and
    joined with the one-hot (``width``: ``roles * hidden + roles``)."""

    def __init__(self, stacks: Mapping[str, RoleStack], roles: int, hidden: int):
        super().__init__()
        self.roles, self.keys = roles, list(stacks)
        self.sizes = [stacks[key].sizes for key in self.keys]
        self.layers = nn.ModuleList(
            nn.Sequential(nn.Linear(sum(sizes[k] for sizes in self.sizes), hidden), nn.ReLU())
            for k in range(roles)
        )
        self.width = roles * hidden + roles

    def forward(self, encodings: Mapping[str, torch.Tensor]) -> torch.Tensor:
        role = encodings[ROLE]
        per_entry = [
            encodings[key].split(sizes, dim=1) for key, sizes in zip(self.keys, self.sizes)
        ]
        out = []
        for k, layer in enumerate(self.layers):
            mine = torch.cat([parts[k] for parts in per_entry], dim=1)
            out.append(role[:, k : k + 1] * layer(mine))
        return torch.cat([*out, role], dim=1)


def check_roles(entries: Mapping[str, Sequence[int]], roles: int, memory: str, frames: int) -> None:
    """``ValueError`` unless ``roles`` networks can read ``entries``: a padded
    observation whose ``role`` entry has ``roles`` values, read one step at a time."""
    if roles < 2:
        raise ValueError(f"roles {roles}: a network for each of at least 2 roles")
    if list(entries.get(ROLE, ())) != [roles]:
        raise ValueError(
            f"a network for each of {roles} roles reads a padded observation whose "
            f"{ROLE!r} entry has {roles} values; its entries are {dict(entries)}"
        )
    if memory != "none" or frames > 1:
        raise ValueError("a network for each role is feed-forward (no memory, one frame)")
