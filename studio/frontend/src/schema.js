// Completion and hover help for scenario YAML from the scenario format's JSON schema.
// The key path at a position is read from the indentation of the lines above it (block
// mappings and "- " list items), which is how scenario files are written.

const KEY_LINE = /^(\s*)(-\s+)?([A-Za-z_][\w]*)\s*:(.*)$/;

function resolve(schema, node, depth = 0) {
  if (!node || depth > 16) return node || {};
  if (node.$ref) {
    const target = node.$ref.replace(/^#\//, "").split("/").reduce((n, key) => n && n[key], schema);
    return resolve(schema, { ...target, ...node, $ref: undefined }, depth + 1);
  }
  return node;
}

function options(schema, node) {
  const resolved = resolve(schema, node);
  const variants = [...(resolved.anyOf || []), ...(resolved.oneOf || []), ...(resolved.allOf || [])];
  return [resolved, ...variants.map((v) => resolve(schema, v)).flatMap((v) => options(schema, v))];
}

function properties(schema, node) {
  const found = {};
  for (const option of options(schema, node)) Object.assign(found, option.properties || {});
  return found;
}

function child(schema, node, key) {
  if (key === "[]") {
    for (const option of options(schema, node)) if (option.items) return option.items;
    return {};
  }
  return properties(schema, node)[key] || {};
}

/** The schema node at a key path (keys, and "[]" for a list item). */
export function nodeAt(schema, path) {
  return path.reduce((node, key) => child(schema, node, key), schema);
}

/** The key path enclosing a line of `indent` columns, read from the lines above `lineNo`. */
export function pathAbove(doc, lineNo, indent) {
  const path = [];
  let column = indent;
  for (let n = lineNo - 1; n >= 1 && column > 0; n--) {
    const text = doc.line(n).text;
    if (!text.trim() || text.trim().startsWith("#")) continue;
    const lead = text.length - text.trimStart().length;
    const match = KEY_LINE.exec(text);
    const dash = /^\s*-\s/.test(text);
    if (dash && lead < column) {
      // "- key: value" opens a list item whose keys sit past the dash.
      path.unshift("[]");
      column = lead;
      continue;
    }
    if (match && lead < column && !dash && !match[4].trim()) {
      path.unshift(match[3]);
      column = lead;
    }
  }
  return path;
}

function typeOf(schema, node) {
  const names = new Set();
  for (const option of options(schema, node)) {
    if (option.type) names.add(option.type);
    if (option.enum) names.add(option.enum.map((v) => JSON.stringify(v)).join(" | "));
    if (option.const !== undefined) names.add(JSON.stringify(option.const));
  }
  return [...names].join(" or ");
}

function describe(schema, key, node) {
  const resolved = resolve(schema, node);
  const parts = [`${key}: ${typeOf(schema, node) || "value"}`];
  const description = resolved.description || options(schema, node).find((o) => o.description)?.description;
  if (description) parts.push(description.replace(/``/g, "`"));
  if (resolved.default !== undefined && typeof resolved.default !== "object") {
    parts.push(`default: ${JSON.stringify(resolved.default)}`);
  }
  return parts.join("\n");
}

/** A CodeMirror completion source over `schema`. */
export function schemaCompletion(schema) {
  return (context) => {
    const line = context.state.doc.lineAt(context.pos);
    const before = line.text.slice(0, context.pos - line.from);
    const keyMatch = /^(\s*)(-\s+)?([A-Za-z_]\w*)?$/.exec(before);
    if (keyMatch) {
      const indent = keyMatch[1].length + (keyMatch[2] ? keyMatch[2].length : 0);
      let path = pathAbove(context.state.doc, line.number, indent);
      if (keyMatch[2]) path = [...pathAbove(context.state.doc, line.number, keyMatch[1].length), "[]"];
      const word = keyMatch[3] || "";
      if (!word && !context.explicit) return null;
      const props = properties(schema, nodeAt(schema, path));
      const names = Object.keys(props);
      if (!names.length) return null;
      return {
        from: context.pos - word.length,
        options: names.map((name) => ({
          label: name,
          type: "property",
          apply: `${name}: `,
          detail: typeOf(schema, props[name]),
          info: describe(schema, name, props[name]),
        })),
        validFor: /^\w*$/,
      };
    }
    const valueMatch = /^(\s*)(-\s+)?([A-Za-z_]\w*)\s*:\s*(\w*)$/.exec(before);
    if (!valueMatch) return null;
    const indent = valueMatch[1].length + (valueMatch[2] ? valueMatch[2].length : 0);
    const path = [...pathAbove(context.state.doc, line.number, indent), valueMatch[3]];
    const values = [];
    for (const option of options(schema, nodeAt(schema, path))) {
      for (const value of option.enum || []) values.push(value);
      if (option.const !== undefined) values.push(option.const);
      if (option.type === "boolean") values.push(true, false);
    }
    if (!values.length) return null;
    return {
      from: context.pos - valueMatch[4].length,
      options: [...new Set(values)].map((v) => ({ label: String(v), type: "enum" })),
    };
  };
}

/** The hover text for the key under `pos`, or null. */
export function hoverText(schema, doc, pos) {
  const line = doc.lineAt(pos);
  const match = KEY_LINE.exec(line.text);
  if (!match) return null;
  const start = line.from + match[1].length + (match[2] ? match[2].length : 0);
  if (pos < start || pos > start + match[3].length) return null;
  const indent = match[1].length + (match[2] ? match[2].length : 0);
  let path = pathAbove(doc, line.number, indent);
  if (match[2]) path = [...pathAbove(doc, line.number, match[1].length), "[]"];
  const node = nodeAt(schema, [...path, match[3]]);
  if (!Object.keys(node).length) return null;
  return { from: start, to: start + match[3].length, text: describe(schema, match[3], node) };
}
