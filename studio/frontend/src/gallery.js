// The gallery: every shipped scenario and every file of the studio's folders.
import { el, getJson, pictureUrl, setStatus } from "./api.js";

export async function showGallery(page) {
  setStatus("loading the scenarios…");
  const grid = el("div", { class: "gallery", id: "gallery" });
  page.append(el("h1", {}, "Gallery"), grid);
  const cards = await getJson("/api/gallery");
  for (const card of cards) {
    const ref = encodeURIComponent(card.ref);
    const where = card.folder === null ? "shipped" : `folder ${card.folder}`;
    const facts = card.error
      ? el("p", { class: "error" }, card.error)
      : el(
          "p",
          { class: "facts" },
          `${card.n_agents} agent(s)`,
          card.gym_id ? el("code", { class: "gym-id" }, card.gym_id) : null,
        );
    grid.append(
      el(
        "article",
        { class: "card", "data-ref": card.ref },
        card.error
          ? el("div", { class: "no-picture" }, "cannot be drawn")
          : el("img", { src: pictureUrl(card.ref), alt: `the layout of ${card.name}`, loading: "lazy" }),
        el("h2", {}, card.name, el("small", {}, ` ${where}`)),
        el("p", { class: "description" }, card.description || ""),
        facts,
        el(
          "p",
          { class: "actions" },
          el("a", { href: `#/editor?ref=${ref}` }, "Edit"),
          card.error ? null : el("a", { href: `#/watch?ref=${ref}` }, "Watch"),
          card.error ? null : el("a", { href: `#/play?ref=${ref}` }, "Play"),
        ),
      ),
    );
  }
  setStatus(`${cards.length} scenarios`);
}
