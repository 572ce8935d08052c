// Requests to the studio's server. The page was opened with the token (if the studio
// has one) and the server set it as a cookie, which every request below carries. Each
// request names this page (X-Studio-Client): the server runs a page's heavy jobs one at
// a time and answers a superseded one 409, which callers treat as "never mind".

const CLIENT = Array.from({ length: 4 }, () => Math.random().toString(36).slice(2, 10)).join("");
const HEADERS = { "x-studio-client": CLIENT };
export const SUPERSEDED = 409;

export function stale(error) {
  return error.name === "AbortError" || (error instanceof ApiError && error.status === SUPERSEDED && error.body.error?.startsWith("superseded"));
}

export class ApiError extends Error {
  constructor(message, status, body) {
    super(message);
    this.status = status;
    this.body = body;
  }
}

async function answer(response) {
  const type = response.headers.get("content-type") || "";
  if (response.ok) return type.includes("json") ? response.json() : response.blob();
  const body = type.includes("json") ? await response.json() : { error: await response.text() };
  throw new ApiError(body.error || `HTTP ${response.status}`, response.status, body);
}

export async function getJson(path, params = {}, signal = undefined) {
  const query = new URLSearchParams(params).toString();
  return answer(await fetch(query ? `${path}?${query}` : path, { headers: HEADERS, signal }));
}

export async function post(path, body, signal = undefined) {
  const response = await fetch(path, {
    method: "POST",
    headers: { ...HEADERS, "content-type": "application/json" },
    body: body === undefined ? undefined : JSON.stringify(body),
    signal,
  });
  return answer(response);
}

// One request at a time for one purpose: a new one aborts the one before.
export function latestOnly() {
  let controller = null;
  return () => {
    if (controller) controller.abort();
    controller = new AbortController();
    return controller.signal;
  };
}

export function socketUrl(path) {
  const scheme = location.protocol === "https:" ? "wss:" : "ws:";
  return `${scheme}//${location.host}${path}`;
}

export function pictureUrl(ref, seed = 0) {
  return `/api/picture?${new URLSearchParams({ ref, seed })}`;
}

let info = null;
export async function studioInfo() {
  info = info || (await getJson("/api/info"));
  return info;
}

export function el(tag, attributes = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attributes)) {
    if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
    else if (value !== null && value !== undefined && value !== false) node.setAttribute(key, value);
  }
  for (const child of children.flat()) {
    if (child !== null && child !== undefined) node.append(child);
  }
  return node;
}

export function setStatus(text, isError = false) {
  const status = document.getElementById("status");
  status.textContent = text;
  status.className = isError ? "error" : "";
}
