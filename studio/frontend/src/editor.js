// The editor: a scenario's YAML in CodeMirror (completion and hover from the JSON
// schema), checked by the server after a short pause with each problem at its line, and
// a live preview of the layout at a chosen seed. "Save as" writes into a studio folder.
import { EditorView, basicSetup } from "codemirror";
import { yaml } from "@codemirror/lang-yaml";
import { linter, lintGutter, forceLinting } from "@codemirror/lint";
import { autocompletion } from "@codemirror/autocomplete";
import { hoverTooltip } from "@codemirror/view";
import { ApiError, el, getJson, latestOnly, post, setStatus, stale, studioInfo } from "./api.js";
import { hoverText, schemaCompletion } from "./schema.js";

const PAUSE_MS = 500;
const STARTER = "extends: fruits_poisons\nn_agents: 2\n";

export async function showEditor(page, params) {
  const ref = params.get("ref");
  const [info, schema, loaded] = await Promise.all([
    studioInfo(),
    getJson("/api/schema"),
    ref ? getJson("/api/scenario", { ref }) : Promise.resolve({ text: STARTER }),
  ]);
  const folder = ref && /^\d+:/.test(ref) ? Number(ref.split(":")[0]) : null;
  let seed = 0;
  let previewUrl = null;
  let latest = 0;
  const validateSignal = latestOnly();
  const previewSignal = latestOnly();

  const problemsList = el("ul", { class: "problems", id: "problems" });
  const preview = el("img", { id: "preview", alt: "the layout at this seed" });
  const seedInput = el("input", { id: "seed", type: "number", min: "0", value: "0" });
  const host = el("div", { class: "code", id: "code" });

  async function check(view) {
    const text = view.state.doc.toString();
    const asked = ++latest;
    let answer;
    try {
      const body = folder === null ? { text } : { text, folder };
      answer = await post("/api/validate", body, validateSignal());
    } catch (error) {
      if (!stale(error)) setStatus(String(error.message), true);
      return [];
    }
    if (asked !== latest) return [];
    showProblems(answer.problems);
    if (answer.ok) refreshPreview(text);
    return answer.problems
      .filter((p) => p.line && p.source === "<editor>")
      .map((p) => {
        const line = view.state.doc.line(Math.min(p.line, view.state.doc.lines));
        return {
          from: line.from,
          to: line.to,
          severity: "error",
          message: p.path ? `${p.path}: ${p.message}` : p.message,
        };
      });
  }

  function showProblems(problems) {
    problemsList.replaceChildren(
      ...problems.map((p) =>
        el(
          "li",
          { class: "problem", "data-line": p.line ?? "" },
          p.line ? el("b", {}, `line ${p.line}`) : null,
          p.source !== "<editor>" ? ` (${p.source})` : "",
          ` ${p.path ? p.path + ": " : ""}${p.message}`,
        ),
      ),
    );
    setStatus(problems.length ? `${problems.length} problem(s)` : "valid");
  }

  async function refreshPreview(text) {
    const asked = latest;
    try {
      const body = { text, seed };
      if (folder !== null) body.folder = folder;
      const blob = await post("/api/preview", body, previewSignal());
      if (asked !== latest) return;
      if (previewUrl) URL.revokeObjectURL(previewUrl);
      previewUrl = URL.createObjectURL(blob);
      preview.src = previewUrl;
      preview.dataset.seed = String(seed);
    } catch (error) {
      if (stale(error)) return;
      if (error instanceof ApiError && error.body.problems) showProblems(error.body.problems);
      else setStatus(String(error.message), true);
    }
  }

  const view = new EditorView({
    doc: loaded.text,
    parent: host,
    extensions: [
      basicSetup,
      yaml(),
      lintGutter(),
      linter(check, { delay: PAUSE_MS }),
      autocompletion({ override: [schemaCompletion(schema)] }),
      hoverTooltip((v, pos) => {
        const found = hoverText(schema, v.state.doc, pos);
        if (!found) return null;
        return {
          pos: found.from,
          end: found.to,
          create: () => ({ dom: el("pre", { class: "hover" }, found.text) }),
        };
      }),
    ],
  });
  window.studioEditor = view; // for checks from the browser tests

  function setSeed(value) {
    seed = Math.max(0, Math.min(4294967295, Math.floor(Number(value) || 0)));
    seedInput.value = String(seed);
    refreshPreview(view.state.doc.toString());
  }
  seedInput.addEventListener("change", () => setSeed(seedInput.value));

  const folderSelect = el(
    "select",
    { id: "save-folder" },
    info.folders.map((name, i) => el("option", { value: String(i) }, `${i}: ${name}`)),
  );
  const nameInput = el("input", { id: "save-name", placeholder: "my_world.yaml" });
  async function save(overwrite = false) {
    const body = {
      text: view.state.doc.toString(),
      folder: Number(folderSelect.value),
      name: nameInput.value.trim(),
      overwrite,
    };
    try {
      const made = await post("/api/save", body);
      setStatus(`saved as ${made.ref}`);
    } catch (error) {
      if (error.status === 409 && confirm(`${body.name} exists: replace it?`)) return save(true);
      setStatus(String(error.message), true);
    }
  }
  const saveBar = info.folders.length
    ? el("p", { class: "save" }, "Save as ", folderSelect, nameInput,
        el("button", { id: "save", onclick: () => save() }, "Save"))
    : el("p", { class: "save" }, "Start the studio with --scenarios DIR to save files.");

  page.append(
    el("h1", {}, "Editor ", el("small", {}, ref || "new scenario")),
    el(
      "div",
      { class: "editor" },
      el("section", {}, host, problemsList, saveBar),
      el(
        "section",
        { class: "side" },
        el("p", { class: "seed" }, "Seed ",
          el("button", { id: "seed-down", onclick: () => setSeed(seed - 1) }, "◀"),
          seedInput,
          el("button", { id: "seed-up", onclick: () => setSeed(seed + 1) }, "▶")),
        preview,
      ),
    ),
  );
  forceLinting(view);
  return () => {
    view.destroy();
    if (previewUrl) URL.revokeObjectURL(previewUrl);
    delete window.studioEditor;
  };
}
