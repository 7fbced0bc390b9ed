// Starts the embedded rerun web viewer for every recording block of a page.
//
// `icil_paper.viz.viewer.show_recording` writes a block like
//   <figure class="icil-recording" data-recordings='[{"label", "rrd", "png"}]' data-height="480px">
//     <div class="icil-recording-viewer"></div>
//     <img class="icil-recording-fallback" src="...png">
//     <figcaption>... <a class="icil-recording-download" href="...rrd"> ...</figcaption>
//   </figure>
// where "rrd" and "png" are paths relative to the book's _static/ folder, which is where
// this module lives. The viewer (npm @rerun-io/web-viewer, vendored by `make book` into
// _static/vendor/rerun-web-viewer/) is imported only on pages that have a block.
//
// The static picture stays visible until the viewer has started, so a reader whose browser
// cannot start it (JavaScript off, a page opened from file:// where module and wasm fetches
// are blocked, no WebGL) still sees the recording. Each block's `data-viewer` attribute says
// how far it got, for the book's browser check: "starting", "started", "open" (the viewer
// reported the recording loaded; `data-opened` says which) or "failed" (the reason is in
// `data-viewer-error`). A block with several recordings has a menu that switches the one
// viewer between them.

const STATIC = new URL("./", import.meta.url);
const VIEWER = new URL("vendor/rerun-web-viewer/index.js", STATIC);

// The viewer focuses its canvas when it starts, and the browser scrolls the page to it: a
// reader opening a chapter would land on the viewer, and the arrow keys and space would
// drive the viewer instead of scrolling the page. So a viewer's canvas takes focus only
// after the reader has clicked into that viewer, and never scrolls the page for it.
const nativeFocus = HTMLElement.prototype.focus;
HTMLCanvasElement.prototype.focus = function (options) {
  const block = this.closest("figure.icil-recording");
  if (!block) return nativeFocus.call(this, options);
  if (block.dataset.engaged === "yes") {
    return nativeFocus.call(this, { ...options, preventScroll: true });
  }
};

function fail(block, error) {
  block.dataset.viewer = "failed";
  block.dataset.viewerError = String(error && error.message ? error.message : error);
  block.querySelector(".icil-recording-viewer")?.replaceChildren();
  const note = document.createElement("p");
  note.className = "icil-recording-note";
  note.textContent = "The interactive viewer could not start here " +
    `(${block.dataset.viewerError}); the static picture shows the recording.`;
  block.querySelector("figcaption")?.prepend(note);
}

function select(block, items, index) {
  const fallback = block.querySelector(".icil-recording-fallback");
  if (fallback && items[index].png) {
    fallback.src = new URL(items[index].png, STATIC).href;
    fallback.alt = `static picture of the recording: ${items[index].label}`;
  }
}

async function start(block, WebViewer) {
  const items = JSON.parse(block.dataset.recordings);
  const host = block.querySelector(".icil-recording-viewer");
  const fallback = block.querySelector(".icil-recording-fallback");
  block.dataset.viewer = "starting";
  // Links work without this module too (relative to the page); here they are made
  // independent of the page's depth in the book.
  block.querySelectorAll("a.icil-recording-download").forEach((a) => {
    a.href = new URL(a.dataset.rrd, STATIC).href;
  });
  block.addEventListener("pointerdown", () => { block.dataset.engaged = "yes"; },
    { capture: true });
  const viewer = new WebViewer();
  viewer.on("recording_open", (event) => {
    block.dataset.viewer = "open";
    block.dataset.opened = block.dataset.current;
    block.dataset.sdkVersion = event.version ?? "";
  });
  try {
    await viewer.start(null, host, {
      hide_welcome_screen: true,
      // A book column is narrow: the views and the timeline get the room.
      panel_state_overrides: { blueprint: "Collapsed", selection: "Collapsed" },
      width: "100%",
      height: block.dataset.height || "480px",
    });
  } catch (error) {
    fail(block, error);
    return;
  }
  if (!host.querySelector("canvas")) {
    fail(block, "no canvas");
    return;
  }
  block.dataset.viewer = "started";
  if (fallback) fallback.hidden = true;
  let current = new URL(items[0].rrd, STATIC).href;
  block.dataset.current = items[0].rrd;
  viewer.open(current);
  if (items.length > 1) {
    // One viewer per block; a menu picks which recording it shows.
    const menu = document.createElement("select");
    menu.className = "icil-recording-menu";
    items.forEach((item, i) => menu.add(new Option(item.label, String(i))));
    const label = document.createElement("label");
    label.className = "icil-recording-menu-label";
    label.append("Recording shown: ", menu);
    menu.addEventListener("change", () => {
      const next = new URL(items[Number(menu.value)].rrd, STATIC).href;
      block.dataset.viewer = "started";
      block.dataset.current = items[Number(menu.value)].rrd;
      viewer.close(current);
      viewer.open(next);
      current = next;
      select(block, items, Number(menu.value));
    });
    host.before(label);
  }
}

async function main() {
  const blocks = [...document.querySelectorAll("figure.icil-recording")];
  if (blocks.length === 0) return;
  let WebViewer;
  try {
    ({ WebViewer } = await import(VIEWER.href));
  } catch (error) {
    blocks.forEach((block) => fail(block, `viewer assets not loaded: ${error}`));
    return;
  }
  // One after another: each viewer compiles and starts its own WebGL context.
  for (const block of blocks) await start(block, WebViewer);
}

main();
