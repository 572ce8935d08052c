// The studio's pages, chosen by the address's hash: #/gallery, #/editor?ref=R,
// #/watch?ref=R, #/play?ref=R.
import "./style.css";
import { showGallery } from "./gallery.js";
import { showEditor } from "./editor.js";
import { showEpisode } from "./episode.js";
import { setStatus } from "./api.js";

let leave = null;

function route() {
  const [name, query] = (location.hash.replace(/^#\/?/, "") || "gallery").split("?");
  const params = new URLSearchParams(query || "");
  const page = document.getElementById("page");
  if (leave) leave();
  leave = null;
  page.replaceChildren();
  setStatus("");
  for (const link of document.querySelectorAll("nav a")) {
    link.classList.toggle("active", link.dataset.page === name);
  }
  const pages = {
    gallery: () => showGallery(page),
    editor: () => showEditor(page, params),
    watch: () => showEpisode(page, params, "watch"),
    play: () => showEpisode(page, params, "play"),
  };
  const shown = (pages[name] || pages.gallery)();
  Promise.resolve(shown)
    .then((cleanup) => {
      leave = cleanup || null;
    })
    .catch((error) => setStatus(String(error.message || error), true));
}

window.addEventListener("hashchange", route);
route();
