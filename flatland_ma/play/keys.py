"""Keys to actions, and where the keys come from (the keyboard, or a script).

Keys are named as pygame names them (``up``, ``left``, ``space``, ``tab``, ``q``), so the
map from keys to actions is a plain function of the agent's action names, testable
without a window. The map, for every scenario:

===============  ==============================  =====================================
key              discrete action                 continuous entry
===============  ==============================  =====================================
up / down        forward / -                     longitudinal +1 / -1
left / right     rotate_left / rotate_right      angular +1 / -1 (counter-clockwise +)
a / d            -                               lateral +1 / -1 (to the left +)
space            stay (if the body has parts)    wait (every entry 0)
q / e            head_left / head_right          head +1 / -1
g / r            grasp / release (first hand)    its grip +1 / -1
z x, c v, b n,   each further control's two      each further control +1 / -1 (arm
1 2, ... 9 0     macros (arm_left / arm_right)   joints, further hands), in order
m k l o p u i y  the next word said (say_0,      the same (the word's entry is set to
                 say_1, ...)                     the middle of the word's bin)
===============  ==============================  =====================================

With a discrete body, several keys held at once give the first of their actions in
action order. With a continuous one, the entries add up. With a channel, each word
said is chosen by its key (a press moves to the next word of the vocabulary, round) and
said with every action until changed; choosing a word is no step.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable
from dataclasses import dataclass

import numpy as np

BASE_DISCRETE = {"forward": "up", "rotate_left": "left", "rotate_right": "right", "stay": "space"}
BASE_CONTINUOUS = {
    "longitudinal": ("up", "down"),
    "lateral": ("a", "d"),
    "angular": ("left", "right"),
}
HEAD_KEYS = ("q", "e")
GRIP_KEYS = ("g", "r")
MORE_KEYS = (("z", "x"), ("c", "v"), ("b", "n"), ("1", "2"), ("3", "4"), ("5", "6"), ("7", "8"))
MORE_KEYS += (("9", "0"),)
"""Key pairs for the controls beyond the base, the head and the first hand, in order."""
WORD_KEYS = ("m", "k", "l", "o", "p", "u", "i", "y")
"""The key that chooses the next word of each word said (``say_0``, ``say_1``, ...)."""
SAY = "say_"
NEXT_AGENT, QUIT = "tab", "escape"


@dataclass(frozen=True)
class Binding:
    """One key: the discrete action or continuous entry ``index`` it drives (-1: none,
    a step that does nothing), by ``value`` (continuous only), and what it is called."""

    key: str
    index: int
    value: float
    label: str


def _control_keys(controls: list[tuple[str, str, str]]) -> list[tuple[str, str]]:
    """A key pair for each control (its name, plus macro, minus macro), as in the table."""
    pairs, more, hands = [], iter(MORE_KEYS), 0
    for name, plus, _ in controls:
        if name == "head":
            pairs.append(HEAD_KEYS)
        elif (name.endswith("grip") or plus.endswith("grasp")) and hands == 0:
            pairs.append(GRIP_KEYS)
            hands += 1
        else:
            pairs.append(next(more, ("", "")))  # past the last pair: no keys
    return pairs


class KeyMap:
    """Which held keys make which action, for one agent's action ``names``.

    ``words`` words said each step (the last ``words`` names, ``say_0`` ...), each one of
    ``vocabulary``: a discrete agent's action is then ``[macro, word, ...]`` (its space a
    ``MultiDiscrete``), a continuous one's Box ends with an entry per word."""

    def __init__(self, names: Iterable[str], discrete: bool, words: int = 0, vocabulary: int = 2):
        self.names = tuple(names)
        self.discrete = discrete
        if not 0 <= words <= min(len(WORD_KEYS), len(self.names)):
            raise ValueError(f"{words} words said: 0 to {len(WORD_KEYS)}")
        self.vocabulary = vocabulary
        self.said = [0] * words
        """The word each token says with the next action (chosen with ``WORD_KEYS``)."""
        moves = self.names[: len(self.names) - words]
        self.moves = len(moves)
        bindings: list[Binding] = []
        if discrete:
            for i, name in enumerate(moves[:4]):
                if name in BASE_DISCRETE:
                    bindings.append(Binding(BASE_DISCRETE[name], i, 1.0, name))
            macros = moves[4:]  # after stay: each control's plus and minus macros
            pairs = [(a.removesuffix("_left"), a, b) for a, b in zip(macros[::2], macros[1::2])]
            for i, keys in enumerate(_control_keys(pairs)):
                for key, offset in zip(keys, (0, 1)):
                    if key:
                        index = 4 + 2 * i + offset
                        bindings.append(Binding(key, index, 1.0, self.names[index]))
        else:
            for i, name in enumerate(moves[:3]):
                plus, minus = BASE_CONTINUOUS[name]
                bindings += [Binding(plus, i, 1.0, f"{name}+"), Binding(minus, i, -1.0, f"{name}-")]
            bindings.append(Binding("space", -1, 0.0, "wait"))
            controls = [(name, name, name) for name in moves[3:]]
            for i, (plus, minus) in enumerate(_control_keys(controls)):
                name = moves[3 + i]
                if plus:
                    bindings.append(Binding(plus, 3 + i, 1.0, f"{name}+"))
                    bindings.append(Binding(minus, 3 + i, -1.0, f"{name}-"))
        self.bindings = tuple(bindings)
        self.word_keys = WORD_KEYS[:words]
        self.keys = frozenset(b.key for b in bindings) | frozenset(self.word_keys)
        """Every key this map reads."""

    @staticmethod
    def for_space(names: Iterable[str], space, vocabulary: int = 2) -> KeyMap:
        """The map for an agent's action ``space`` (``Discrete``, ``MultiDiscrete``:
        the macro then the words, or ``Box``) and its action ``names``."""
        from gymnasium import spaces

        names = tuple(names)
        if isinstance(space, spaces.Discrete):
            return KeyMap(names, True)
        if isinstance(space, spaces.MultiDiscrete):
            nvec = [int(n) for n in np.asarray(space.nvec).ravel()]
            return KeyMap(names, True, len(nvec) - 1, max(nvec[1:], default=2))
        words = len(names) - len(tuple(n for n in names if not n.startswith(SAY)))
        return KeyMap(names, False, words, vocabulary)

    def press(self, pressed: Collection[str]) -> bool:
        """Choose the next word of each token whose key went down; whether any did."""
        chosen = False
        for j, key in enumerate(self.word_keys):
            if key in pressed:
                self.said[j] = (self.said[j] + 1) % self.vocabulary
                chosen = True
        return chosen

    def action(self, keys: Collection[str]):
        """The action for these held keys, or None when none of them is an action key.
        Discrete: the first bound action in action order (with the words chosen, as an
        int64 array, if the agent speaks). Continuous: the sum of the held keys'
        entries, each in [-1, 1] (float32, like the action space), and each word's."""
        held = [b for b in self.bindings if b.key in keys]
        if not held:
            return None
        if self.discrete:
            macro = min(b.index for b in held)
            return np.array([macro, *self.said], np.int64) if self.said else macro
        action = np.zeros(len(self.names), np.float32)
        for b in held:
            if b.index >= 0:
                action[b.index] += b.value
        for j, word in enumerate(self.said):  # the middle of the word's bin of [-1, 1]
            action[self.moves + j] = (2.0 * word + 1.0) / self.vocabulary - 1.0
        return np.clip(action, -1.0, 1.0)

    def help(self) -> list[str]:
        """``key: what it does`` for every key, in action order."""
        words = [f"{k}: next word of {SAY}{j}" for j, k in enumerate(self.word_keys)]
        return [f"{b.key}: {b.label}" for b in self.bindings] + words


@dataclass(frozen=True)
class Keys:
    """One frame's keyboard: keys that went down in it, keys held at its end, and
    whether the window was asked to close."""

    pressed: frozenset[str] = frozenset()
    held: frozenset[str] = frozenset()
    quit: bool = False

    @property
    def down(self) -> frozenset[str]:
        """Keys held, or tapped within the frame (down and up again): each acts once."""
        return self.pressed | self.held


SCRIPT_KEYS = frozenset(
    [*BASE_DISCRETE.values(), *(k for pair in BASE_CONTINUOUS.values() for k in pair)]
    + [*HEAD_KEYS, *GRIP_KEYS, *(k for pair in MORE_KEYS for k in pair), *WORD_KEYS]
    + [NEXT_AGENT, QUIT]
)
"""The keys a script may name: every key of the table, Tab and Esc (and ``wait``)."""
MAX_SCRIPT_FRAMES = 1_000_000
"""Frames a key script may last in all (over nine hours at 30 frames a second)."""
MAX_SCRIPT_WORDS = 100_000


def parse_script(script: str) -> list[tuple[frozenset[str], int]]:
    """A key script as runs of (keys held together, frames held); ``ValueError`` naming
    the word for a key not in ``SCRIPT_KEYS``, a count that is not a whole number from 1,
    or a script longer than ``MAX_SCRIPT_FRAMES`` frames. Nothing is expanded."""
    words = script.split(maxsplit=MAX_SCRIPT_WORDS)
    if len(words) > MAX_SCRIPT_WORDS:
        raise ValueError(f"key script: more than {MAX_SCRIPT_WORDS:,} words")
    runs: list[tuple[frozenset[str], int]] = []
    total = 0
    for word in words:
        keys, star, count = word.partition("*")
        if star and not (count.isascii() and count.isdigit() and len(count) <= 12):
            raise ValueError(f"key script: {word!r}: after * comes a number of frames")
        n = int(count) if star else 1
        if n < 1:
            raise ValueError(f"key script: {word!r} holds keys for fewer than one frame")
        names = frozenset() if keys == "wait" else frozenset(keys.split("+"))
        unknown = sorted(k for k in names if k not in SCRIPT_KEYS)
        if unknown or not keys:
            raise ValueError(
                f"key script: {word!r}: no key {', '.join(unknown) or keys!r}; keys: "
                f"{', '.join(sorted(SCRIPT_KEYS))}, or wait"
            )
        total += n
        if total > MAX_SCRIPT_FRAMES:
            raise ValueError(
                f"key script: {total:,} frames by {word!r}; at most {MAX_SCRIPT_FRAMES:,}"
            )
        runs.append((names, n))
    return runs


class ScriptedKeys:
    """Keys from a script instead of the keyboard, for demos and checks: words separated
    by spaces, each a key name, ``name*N`` (held for N frames) or ``a+b*N`` (held
    together); ``wait*N`` is N frames with no key. After the last word: quit. The script
    is checked whole first (``parse_script``) and played a frame at a time."""

    def __init__(self, script: str):
        self.runs = parse_script(script)
        self._run, self._frame = 0, 0

    def poll(self, events: list) -> Keys:
        """The script's next frame (the window's events are not read)."""
        if self._run >= len(self.runs):
            return Keys(quit=True)
        names, n = self.runs[self._run]
        first = self._frame == 0
        self._frame += 1
        if self._frame == n:
            self._run, self._frame = self._run + 1, 0
        return Keys(pressed=names, held=names) if first else Keys(held=names)


class PygameKeys:
    """Keys from pygame's events: a key is held from its key-down event to its key-up
    (so events posted by a test drive it like a keyboard); losing the focus lets go of
    every key."""

    def __init__(self):
        self.held: set[str] = set()

    def poll(self, events: list) -> Keys:
        import pygame

        pressed, quit_ = set(), False
        for event in events:
            if event.type == pygame.KEYDOWN:
                name = pygame.key.name(event.key)
                pressed.add(name)
                self.held.add(name)
            elif event.type == pygame.KEYUP:
                self.held.discard(pygame.key.name(event.key))
            elif event.type == pygame.WINDOWFOCUSLOST:
                self.held.clear()
            elif event.type == pygame.QUIT:
                quit_ = True
        return Keys(frozenset(pressed), frozenset(self.held), quit_)
