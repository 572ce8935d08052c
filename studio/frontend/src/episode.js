// Watch and Play: an episode over the studio's WebSocket. Watch: a policy per agent,
// play / pause / step / speed, the score and infos. Play: the arrow keys (and the other
// keys from the agent's action names) drive one agent, Tab switches agents.
import { el, getJson, setStatus, socketUrl, studioInfo } from "./api.js";

const KEY_NAMES = { ArrowUp: "up", ArrowDown: "down", ArrowLeft: "left", ArrowRight: "right", " ": "space", Tab: "tab" };

function keyName(event) {
  if (KEY_NAMES[event.key]) return KEY_NAMES[event.key];
  return /^[a-z0-9]$/i.test(event.key) ? event.key.toLowerCase() : null;
}

function table(rows, columns) {
  return el(
    "table",
    {},
    el("tr", {}, columns.map((c) => el("th", {}, c))),
    rows.map((row) => el("tr", {}, row.map((cell) => el("td", {}, String(cell))))),
  );
}

export async function showEpisode(page, params, mode) {
  const info = await studioInfo();
  const gallery = await getJson("/api/gallery");
  const usable = gallery.filter((card) => !card.error);
  let ref = params.get("ref") || "fruits_poisons";
  let seed = Number(params.get("seed") || 0);
  let fps = mode === "play" ? Math.min(15, info.limits.fps) : 10;
  const policies = {};
  let others = "greedy";
  let episodeKey = null;
  let socket = null;
  let frameUrl = null;
  let pending = null;
  const held = new Set();
  const pressed = new Set();
  let bindable = new Set(["tab"]);

  const picture = el("img", { id: "frame", alt: "the episode", tabindex: "0" });
  const scoreBox = el("div", { id: "score", class: "score" });
  const infoBox = el("div", { id: "infos" });
  const agentsBox = el("div", { id: "agents" });
  const keysBox = el("div", { id: "keys", class: "keys" });
  const gifLink = el("a", { id: "gif", download: "episode.gif" }, "Download GIF");

  const scenarioSelect = el(
    "select",
    { id: "scenario" },
    usable.map((card) => el("option", { value: card.ref, selected: card.ref === ref }, card.ref)),
  );
  scenarioSelect.addEventListener("change", () => {
    ref = scenarioSelect.value;
    Object.keys(policies).forEach((k) => delete policies[k]);
    start();
  });
  const seedInput = el("input", { id: "seed", type: "number", min: "0", value: String(seed) });
  seedInput.addEventListener("change", () => {
    seed = Math.max(0, Math.floor(Number(seedInput.value) || 0));
    send({ type: "reset", seed });
  });
  const speed = el("input", { id: "speed", type: "range", min: "1", max: String(info.limits.fps), value: String(fps) });
  const speedLabel = el("span", {}, `${fps} fps`);
  speed.addEventListener("input", () => {
    fps = Number(speed.value);
    speedLabel.textContent = `${fps} fps`;
    send({ type: "speed", fps });
  });
  const policyOptions = (chosen) =>
    info.policies.map((p) => el("option", { value: p, selected: p === chosen }, p));
  const othersSelect = el("select", { id: "others" }, policyOptions(others));
  othersSelect.addEventListener("change", () => {
    others = othersSelect.value;
    start();
  });

  function send(message) {
    if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(message));
  }

  function start() {
    const message = { type: "start", mode, scenario: ref, seed, fps };
    if (mode === "watch") message.policies = { ...policies };
    else message.others = others;
    if (socket && socket.readyState === WebSocket.OPEN) send(message);
    else pending = message;
  }

  function showAgents(agents) {
    if (mode !== "watch") return;
    agentsBox.replaceChildren(
      ...agents.map((agent) => {
        const select = el("select", { "data-agent": agent }, policyOptions(policies[agent] || "greedy"));
        select.addEventListener("change", () => {
          policies[agent] = select.value;
          start();
        });
        return el("label", {}, `${agent} `, select);
      }),
    );
  }

  function showState(state) {
    const returns = Object.entries(state.returns || {});
    if (mode === "play") {
      scoreBox.replaceChildren(
        el("span", {}, `driving ${state.agent}`),
        el("span", { id: "score-value", "data-score": state.score }, `score ${state.score}`),
        el("span", {}, `episode ${state.episode}`),
        el("span", { id: "step" , "data-step": state.step }, `step ${state.step}`),
      );
    } else {
      scoreBox.replaceChildren(
        el("span", { id: "step", "data-step": state.step }, `step ${state.step}`),
        el("span", {}, state.done ? "episode over" : ""),
      );
    }
    const infos = state.infos || {};
    infoBox.replaceChildren(
      table(
        returns.map(([agent, value]) => [agent, value, JSON.stringify(infos[agent] ?? "")]),
        ["agent", "return", "infos"],
      ),
    );
  }

  function connect() {
    socket = new WebSocket(socketUrl("/api/episode"));
    socket.binaryType = "blob";
    socket.addEventListener("open", () => {
      if (pending) send(pending);
      pending = null;
    });
    socket.addEventListener("message", (event) => {
      if (typeof event.data !== "string") {
        if (frameUrl) URL.revokeObjectURL(frameUrl);
        frameUrl = URL.createObjectURL(event.data);
        picture.src = frameUrl;
        return;
      }
      const message = JSON.parse(event.data);
      if (message.type === "ready") {
        episodeKey = message.episode;
        gifLink.href = `/api/episodes/${episodeKey}/gif`;
        showAgents(message.agents);
        const lines = Object.values(message.keys || {})[0] || [];
        bindable = new Set(["tab", ...lines.map((line) => line.split(":")[0])]);
        if (mode === "play") {
          const tab = message.agents.length > 1 ? [el("span", {}, "tab: next agent")] : [];
          keysBox.replaceChildren(...lines.map((line) => el("span", {}, line)), ...tab);
        }
        setStatus(`${mode}: ${ref}`);
      } else if (message.type === "state") {
        showState(message);
        picture.dataset.step = String(message.step);
      } else if (message.type === "error") {
        const problems = (message.problems || []).map((p) => ` line ${p.line}: ${p.path} ${p.message}`);
        setStatus(message.message + problems.join(";"), true);
      }
    });
    socket.addEventListener("close", (event) => {
      if (event.code === 1013) setStatus("the studio is busy: too many episodes at once", true);
    });
  }

  function sendKeys() {
    send({ type: "keys", held: [...held], pressed: [...pressed] });
    pressed.clear();
  }
  function keydown(event) {
    const name = keyName(event);
    if (!name || !bindable.has(name) || event.target.closest("select, input")) return;
    event.preventDefault();
    if (!held.has(name)) {
      held.add(name);
      pressed.add(name);
      sendKeys();
    }
  }
  function keyup(event) {
    const name = keyName(event);
    if (!name || !held.has(name)) return;
    event.preventDefault();
    held.delete(name);
    sendKeys();
  }
  function blur() {
    held.clear();
    sendKeys();
  }

  const controls =
    mode === "watch"
      ? el(
          "p",
          { class: "controls" },
          el("button", { id: "play", onclick: () => send({ type: "play" }) }, "Play"),
          el("button", { id: "pause", onclick: () => send({ type: "pause" }) }, "Pause"),
          el("button", { id: "step-once", onclick: () => send({ type: "step" }) }, "Step"),
          " Speed ", speed, speedLabel,
        )
      : el("p", { class: "controls" }, "Others: ", othersSelect, " Click the picture, then use the keys.");
  page.append(
    el("h1", {}, mode === "watch" ? "Watch" : "Play"),
    el("p", { class: "choose" }, "Scenario ", scenarioSelect, " Seed ", seedInput, " ", gifLink),
    controls,
    el("div", { class: "episode" }, el("section", {}, picture, keysBox), el("section", {}, scoreBox, agentsBox, infoBox)),
  );
  if (mode === "play") {
    window.addEventListener("keydown", keydown);
    window.addEventListener("keyup", keyup);
    window.addEventListener("blur", blur);
  }
  connect();
  start();
  return () => {
    window.removeEventListener("keydown", keydown);
    window.removeEventListener("keyup", keyup);
    window.removeEventListener("blur", blur);
    if (socket) socket.close();
    if (frameUrl) URL.revokeObjectURL(frameUrl);
  };
}
