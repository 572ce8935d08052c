"""The options of ``baselines.ppo`` (its command line, through tyro): CleanRL's PPO
settings with their defaults, and the options beyond them (presets, team reward, shaping,
curricula, exploration, memory, overlapped collection, resuming)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal


@dataclass
class Args:
    scenario: str = "fruits_poisons_multi"
    """Scenario to train on; any number of agents, all acting alike (observations that
    differ are padded to one, with each agent's role)."""
    no_channel: bool = False
    """Play the scenario without its channel (``channel: null``): nobody speaks or hears.
    The default log is then runs/ppo/<scenario>-no-channel/."""
    seed: int = 0
    """Seeds torch and numpy; world k of the batch is reset with seed * num_envs + k."""
    total_timesteps: int = 1_000_000
    """Agent-steps to train for, summed over all agents and worlds (steps that act)."""
    csv: str = ""
    """Where to write the episode log; empty means runs/ppo/<scenario>/seed_<seed>.csv."""
    use_depth: bool = False
    """Give the network the depth channel too (the paper's single-agent input is colour only)."""
    num_envs: int = 4
    """Worlds in the batched env; it has num_envs * agents slots."""
    num_steps: int = 128
    """Steps per slot in each rollout (CleanRL's 128)."""
    learning_rate: float = 2.5e-4
    """Adam learning rate, annealed linearly to 0 (CleanRL's default)."""
    anneal_lr: bool = True
    """Anneal the learning rate (CleanRL's default)."""
    gamma: float = 0.99
    """Discount factor (as the paper's baselines)."""
    gae_lambda: float = 0.95
    """GAE lambda (CleanRL's default)."""
    num_minibatches: int = 4
    """Minibatches per epoch (CleanRL's default)."""
    update_epochs: int = 4
    """Epochs over each rollout (CleanRL's default)."""
    norm_adv: bool = True
    """Normalise the advantages over each minibatch (CleanRL's default). Without it the
    policy's step is in proportion to the advantages themselves: where the reward is rare,
    most minibatches carry only the critic's errors, which normalising makes full-sized."""
    clip_coef: float = 0.2
    """PPO clipping coefficient, also used for the value (CleanRL's default)."""
    ent_coef: float = 0.01
    """Entropy bonus weight (CleanRL's default)."""
    vf_coef: float = 0.5
    """Value loss weight (CleanRL's default)."""
    max_grad_norm: float = 0.5
    """Gradients are clipped to this global norm (CleanRL's default)."""
    reward_scale: float = 0.1
    """Rewards are multiplied by this for learning (an item is worth +-1); the log keeps
    the unscaled returns."""
    hidden: int = 128
    """Units of the fully connected layer after the conv trunk (as A3C's)."""
    network: Literal["strided", "paper"] = "strided"
    """The conv trunk: "paper" is the paper's (stride 1, then MaxPool1D(2)); "strided"
    strides its first two convolutions by 4 and 2 (as the Nature DQN's trunk does), about
    6x less work per step for the same three layers' reach."""
    checkpoint_every: int = 50
    """Save a checkpoint every this many updates (0: only the final one)."""
    keep_checkpoints: int = 0
    """Keep only the newest this many of those checkpoints (0: every one)."""
    resume: bool = False
    """Go on from the newest of those checkpoints, if there is one (``baselines.ppo_resume``:
    the same arguments; the worlds start new episodes there)."""
    init_from: str = ""
    """A checkpoint whose network weights the run starts from (its optimiser starts anew):
    one of the same spaces and network options, e.g. the imitator of
    ``baselines.benchmark.imitate``. Empty: random weights. Not with ``resume`` once the
    run has checkpoints of its own (they are what it goes on from)."""
    critic_warmup: int = 0
    """The first this many updates train the critic's head alone, the policy and the
    layers it shares with the critic held as they are: for a run started from a policy
    taught alone (``init_from`` an imitator), whose critic has learnt nothing, so that
    the first advantages come from a critic fitted to that policy's returns. Not with
    ``overlap``."""
    tensorboard: bool = True
    """Write TensorBoard events beside the CSV."""
    torch_threads: int = 1
    """Threads torch may use (checked at the end of the run; the JSON records it)."""
    overlap: bool = False
    """Collect the next rollout while the network updates on the last one, in a thread
    of its own: the rollout is acted by the parameters from before that update (a policy
    lag of one update, as APPO's), which the PPO ratio corrects for. With two cores, about
    twice the agent-steps per second of wall time."""
    shards: int = 1
    """Processes the worlds are spread over (1: all in this process)."""
    critic: Literal["local", "state"] = "local"
    """What the value reads: "local", the agent's own observation (through the policy's
    layers); "state", a centralised critic of its own on the world's global state and
    which agent of the world the slot is (MAPPO)."""
    preset: str = ""
    """Named settings for a task (``baselines.ppo_presets``), applied to every option left
    at its default; empty: none."""
    team_reward: bool = False
    """Every agent learns from its team's reward, the sum of its world's rewards (the log
    keeps each agent's own return): every agent of a world counts as one team, so it is
    refused where teams score against each other (``tug_of_war``'s zero-sum deliveries),
    where the sum is 0."""
    learners: str = ""
    """A team of the scenario whose agents alone learn; every other agent acts at random
    (uniformly over its actions), as the benchmark scores a team against random play.
    Empty: every agent learns."""
    shaping: float = 0.0
    """Weight of the potential-based shaping term (``baselines.shaping``); 0: none. The log
    keeps the scenario's return."""
    shaping_potential: Literal["auto", "delivery", "goal"] = "auto"
    """What the shaping measures: "delivery", the object's way to its zone and the agent's
    to the object; "goal", the whole way the agent still has to walk to a paying thing;
    "auto", delivery where the scenario has deliveries, else goal."""
    shaping_gamma: float = -1.0
    """The shaping term's discount, ``W (shaping_gamma Phi(s') - Phi(s))``: below 0, the
    learner's ``gamma`` (the optimal policies stay as they were); 1, the plain progress
    towards the target each step, without the bonus ``(1 - gamma) |Phi|`` a step that the
    learner's gamma pays for being far away."""
    novelty: float = 0.0
    """Weight of an exploration bonus from the observations alone, random network
    distillation (``baselines.novelty``): the predictor's error on what each step
    returned, over a running scale of it, added to the (scaled) reward; 0: none."""
    curriculum: str = ""
    """A stream file whose tasks the run trains on in turn (``baselines.curriculum``), for
    their steps in all (``total_timesteps`` is then not used); empty: ``scenario`` alone."""
    listening: float = 0.0
    """Weight of a bias towards listening (``baselines.channel_bias``): each step's moves
    made to differ between the words the others said and other words; 0: none."""
    signalling: float = 0.0
    """Weight of a bias towards signalling (``baselines.channel_bias``): words that differ
    between situations and are sure in each; 0: none."""
    anchor: float = 0.0
    """Weight of a pull towards the policy the run starts from (``baselines.anchor``): the
    KL divergence from the ``init_from`` policy's action distribution to the network's, on
    each minibatch, added to the loss (kickstarting); 0: none."""
    anchor_fade: float = 0.0
    """The fraction of the run's updates over which the anchor's weight falls linearly to
    0; 0: held throughout."""
    role_networks: bool = False
    """A network for each role (agents whose observations differ: ``plate_relay``'s scout
    and runner, ``signal_rooms``' guide and seeker), in one module whose every row is
    read by its own role's part alone (``flatland_ma.policies.roles``): the roles share
    no parameters. Off: one network for every agent, told the role by the padded
    observation. Feed-forward only."""
    memory: Literal["none", "gru"] = "none"
    """The policy's recurrent core: "gru", a one-layer GRU of ``memory_size`` units after
    the fully connected layer, its state carried through each episode and trained on whole
    sequences of slots (``baselines.ppo_memory``; minibatches of slots, so at most
    ``num_envs * agents`` of them); "none", a feed-forward policy."""
    memory_size: int = 128
    """Units of the recurrent core."""
    frames: int = 1
    """How many of its last observations the policy reads at once (a frame stack, the
    first observation repeated at an episode's start); 1: the current one alone."""
