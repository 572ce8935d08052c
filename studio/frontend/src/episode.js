// Watch and Play: an episode over the studio's WebSocket. Watch: a policy per agent,
// play / pause / step / speed, the score and infos. Play: the arrow keys (and the other
// keys from the agent's action names) drive one agent, Tab switches agents.
//
// The policies each agent can follow come from /api/policies before the episode starts
// (with each agent's default chosen); a refused choice is marked and can be changed. When
// the server ends the episode (idle, busy, a failure) or the connection drops, the page
// says why and connects again, a few times, starting the same episode.
import { el, getJson, latestOnly, post, setStatus, socketUrl, stale, studioInfo } from "./api.js";

const KEY_NAMES = { ArrowUp: "up", ArrowDown: "down", ArrowLeft: "left", ArrowRight: "right", " ": "space", Tab: "tab" };
const ALIVE_MS = 20000; // the server closes an episode whose page says nothing for 120 s
const RETRIES = 5; // connections again after a drop, each after twice the wait before
const FIRST_RETRY_MS = 1000;
const GIF_POLL_MS = 300;
const DEFAULT = ""; // "others" left to each agent's default

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
  let policies = {}; // agent -> chosen policy (watch)
  let offered = []; // [{agent, policies, default}] from /api/policies
  let others = DEFAULT;
  let episodeKey = null;
  let socket = null;
  let frameUrl = null;
  let wanted = null; // the start message of the episode the page wants
  let retries = 0;
  let retryTimer = null;
  let aliveTimer = null;
  let leaving = false;
  let lastError = null;
  const held = new Set();
  const pressed = new Set();
  let bindable = new Set(["tab"]);
  const policiesSignal = latestOnly();

  const picture = el("img", { id: "frame", alt: "the episode", tabindex: "0", hidden: true });
  const waiting = el("div", { id: "waiting", class: "waiting" }, "connecting...");
  const scoreBox = el("div", { id: "score", class: "score" });
  const infoBox = el("div", { id: "infos" });
  const agentsBox = el("div", { id: "agents" });
  const keysBox = el("div", { id: "keys", class: "keys" });
  const gifButton = el("button", { id: "gif", disabled: true }, "Make GIF");
  const gifState = el("span", { id: "gif-state" });
  const reconnectButton = el("button", { id: "reconnect", hidden: true }, "Connect again");

  const scenarioSelect = el(
    "select",
    { id: "scenario" },
    usable.map((card) => el("option", { value: card.ref, selected: card.ref === ref }, card.ref)),
  );
  scenarioSelect.addEventListener("change", () => {
    ref = scenarioSelect.value;
    policies = {};
    loadPolicies();
  });
  const seedInput = el("input", { id: "seed", type: "number", min: "0", value: String(seed) });
  seedInput.addEventListener("change", () => {
    seed = Math.max(0, Math.floor(Number(seedInput.value) || 0));
    if (wanted) wanted = { ...wanted, seed };
    send({ type: "reset", seed });
  });
  const speed = el("input", { id: "speed", type: "range", min: "1", max: String(info.limits.fps), value: String(fps) });
  const speedLabel = el("span", {}, `${fps} fps`);
  speed.addEventListener("input", () => {
    fps = Number(speed.value);
    speedLabel.textContent = `${fps} fps`;
    if (wanted) wanted = { ...wanted, fps };
    send({ type: "speed", fps });
  });
  const othersSelect = el("select", { id: "others" });
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
    else if (others !== DEFAULT) message.others = others;
    wanted = message;
    for (const select of agentsBox.querySelectorAll("select")) select.classList.remove("refused");
    if (socket && socket.readyState === WebSocket.OPEN) send(message);
    else if (!socket || socket.readyState === WebSocket.CLOSED) connect();
  }

  // The policies each agent can follow, then the episode (the selectors come first).
  async function loadPolicies() {
    setStatus(`${mode}: ${ref}: finding the policies that suit its agents...`);
    try {
      offered = (await getJson("/api/policies", { ref }, policiesSignal())).agents;
    } catch (error) {
      if (!stale(error)) setStatus(String(error.message), true);
      return;
    }
    for (const entry of offered) policies[entry.agent] = policies[entry.agent] || entry.default;
    showPolicies();
    start();
  }

  function showPolicies() {
    if (mode === "watch") {
      agentsBox.replaceChildren(
        ...offered.map((entry) => {
          const chosen = policies[entry.agent];
          const select = el(
            "select",
            { "data-agent": entry.agent },
            entry.policies.map((p) =>
              el("option", { value: p, selected: p === chosen }, p === entry.default ? `${p} (default)` : p),
            ),
          );
          select.addEventListener("change", () => {
            policies[entry.agent] = select.value;
            start();
          });
          return el("label", {}, `${entry.agent} `, select);
        }),
      );
      return;
    }
    // play: one policy for every agent you do not drive, or each its own default
    const common = offered.length
      ? offered.map((e) => e.policies).reduce((a, b) => a.filter((p) => b.includes(p)))
      : [];
    othersSelect.replaceChildren(
      el("option", { value: DEFAULT, selected: others === DEFAULT }, "each its default"),
      ...common.map((p) => el("option", { value: p, selected: p === others }, p)),
    );
  }

  function showState(state) {
    const returns = Object.entries(state.returns || {});
    if (mode === "play") {
      const said = state.said && state.said.length ? [el("span", { id: "said" }, `saying ${state.said.join(" ")}`)] : [];
      scoreBox.replaceChildren(
        el("span", {}, `driving ${state.agent}`),
        el("span", { id: "score-value", "data-score": state.score }, `score ${state.score}`),
        el("span", {}, `episode ${state.episode}`),
        el("span", { id: "step", "data-step": state.step }, `step ${state.step}`),
        ...said,
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

  function showError(message) {
    const problems = (message.problems || []).map((p) => ` line ${p.line}: ${p.path} ${p.message}`);
    setStatus(message.message + problems.join(";"), true);
    if (message.agent) {
      const select = agentsBox.querySelector(`select[data-agent="${CSS.escape(message.agent)}"]`);
      if (select) select.classList.add("refused");
    }
  }

  function connect() {
    clearTimeout(retryTimer);
    reconnectButton.hidden = true;
    lastError = null;
    socket = new WebSocket(socketUrl("/api/episode"));
    const mine = socket;
    socket.binaryType = "blob";
    socket.addEventListener("open", () => {
      if (wanted) send(wanted);
      clearInterval(aliveTimer);
      aliveTimer = setInterval(() => send({ type: "alive" }), ALIVE_MS);
    });
    socket.addEventListener("message", (event) => {
      if (mine !== socket) return;
      if (typeof event.data !== "string") {
        if (frameUrl) URL.revokeObjectURL(frameUrl);
        frameUrl = URL.createObjectURL(event.data);
        picture.src = frameUrl;
        picture.hidden = false;
        waiting.hidden = true;
        return;
      }
      const message = JSON.parse(event.data);
      if (message.type === "ready") {
        retries = 0;
        episodeKey = message.episode;
        gifButton.disabled = false;
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
        if (message.fatal) lastError = message;
        showError(message);
      }
    });
    socket.addEventListener("close", (event) => {
      if (mine !== socket || leaving) return;
      clearInterval(aliveTimer);
      gifButton.disabled = true;
      const why = (lastError && lastError.message) || event.reason || `the connection dropped (code ${event.code})`;
      if (retries >= RETRIES) {
        setStatus(`${why}; press "Connect again"`, true);
        reconnectButton.hidden = false;
        return;
      }
      const wait = FIRST_RETRY_MS * 2 ** retries;
      retries += 1;
      setStatus(`${why}; connecting again in ${Math.round(wait / 1000)} s`, true);
      waiting.textContent = "reconnecting...";
      retryTimer = setTimeout(connect, wait);
    });
  }
  reconnectButton.addEventListener("click", () => {
    retries = 0;
    connect();
  });

  async function makeGif() {
    if (!episodeKey) return;
    gifButton.disabled = true;
    try {
      let job = await post(`/api/episodes/${episodeKey}/gif`);
      while (!job.ready && !job.error) {
        gifState.textContent = `GIF: ${job.done} of ${job.total} frames`;
        await new Promise((resolve) => setTimeout(resolve, GIF_POLL_MS));
        job = await getJson(`/api/gifs/${job.gif}`);
      }
      if (job.error) throw new Error(job.error);
      gifState.textContent = `GIF ready (${(job.bytes / 1e6).toFixed(1)} MB)`;
      const link = el("a", { href: `/api/gifs/${job.gif}/file`, download: "episode.gif" });
      document.body.append(link);
      link.click();
      link.remove();
    } catch (error) {
      gifState.textContent = "";
      setStatus(String(error.message), true);
    } finally {
      gifButton.disabled = !episodeKey;
    }
  }
  gifButton.addEventListener("click", makeGif);

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
    el("p", { class: "choose" }, "Scenario ", scenarioSelect, " Seed ", seedInput, " ", gifButton, " ", gifState, " ", reconnectButton),
    controls,
    el(
      "div",
      { class: "episode" },
      el("section", {}, waiting, picture, keysBox),
      el("section", {}, scoreBox, agentsBox, infoBox),
    ),
  );
  if (mode === "play") {
    window.addEventListener("keydown", keydown);
    window.addEventListener("keyup", keyup);
    window.addEventListener("blur", blur);
  }
  loadPolicies();
  return () => {
    leaving = true;
    clearTimeout(retryTimer);
    clearInterval(aliveTimer);
    window.removeEventListener("keydown", keydown);
    window.removeEventListener("keyup", keyup);
    window.removeEventListener("blur", blur);
    if (socket) socket.close();
    if (frameUrl) URL.revokeObjectURL(frameUrl);
  };
}
