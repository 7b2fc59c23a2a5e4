"""The HTML report's page assets, as tables of text: its style sheet, the script that draws the
interactive figures, and the one-line script that marks the page as scripted. A module of its
own so that :mod:`vrelab.report.html` holds the report's logic only."""

from __future__ import annotations

CSS = """
:root { --ink:#1b1f24; --mute:#5b6570; --rule:#d5dbe1; --warn:#8a4b00; --warnbg:#fff4e0; --accent:#0072B2; }
* { box-sizing: border-box; }
body { font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "Liberation Sans", Arial, sans-serif;
       color: var(--ink); max-width: 980px; margin: 0 auto; padding: 24px 28px 60px; background: #fff; }
h1 { font-size: 1.7em; margin: 0 0 .2em; }
h2 { font-size: 1.35em; margin: 2.2em 0 .3em; padding-top: .6em; border-top: 3px solid var(--rule); }
h3 { font-size: 1.18em; margin: 2em 0 .3em; padding-top: .5em; border-top: 1px solid var(--rule); }
h4 { font-size: 1.0em; margin: 1.4em 0 .4em; color: var(--mute); text-transform: uppercase; letter-spacing: .04em; }
p.lead { font-size: 1.06em; margin: .3em 0 1em; }
p.what { font-size: 1.04em; border-left: 4px solid var(--accent); padding: .3em .8em; background: #f3f8fc; }
p.rule { font-size: 1.04em; border: 1px solid var(--accent); padding: .4em .8em; }
table { border-collapse: collapse; margin: .4em 0 1em; font-size: .92em; }
th, td { border-bottom: 1px solid var(--rule); padding: 3px 10px; text-align: left; vertical-align: top; }
th { background: #f4f6f8; font-weight: 600; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
table.kv th { background: none; color: var(--mute); font-weight: 500; white-space: nowrap; }
/* Headers of numeric columns wrap (their numbers do not): a wide table fits its box. Nested
   field tables (a sensor's description in provenance) wrap inside their cell. */
th.num { white-space: normal; }
table.kv td { overflow-wrap: anywhere; }
table.kv table.kv { margin: 0; }
table.kv table.kv th { white-space: normal; }
td.given-not { color: var(--mute); font-style: italic; }
div.scroll { overflow-x: auto; max-width: 100%; }
/* The prediction's columns (a share per mechanism): headings wrap so the table fits the page. */
table.pred th.num { white-space: normal; }
table.ident { width: 100%; border: 2px solid var(--ink); }
table.ident th { width: 24%; }
table.approval { width: 100%; }
table.approval td.sign { width: 34%; border-bottom: 1px solid var(--ink); height: 3.2em; }
figure { margin: 1em 0 1.4em; }
figure img { max-width: 100%; height: auto; border: 1px solid var(--rule); display: block; }
figcaption { color: var(--mute); font-size: .92em; margin-top: .3em; }
/* The interactive twin shows where the script drew it; the PNG where it did not, and in print. */
.iplot { display: none; }
html.js .iplot { display: block; width: 100%; box-sizing: border-box; overflow: hidden; border: 1px solid var(--rule); }
figure.live img.static { display: none; }
ul.warn { background: var(--warnbg); border: 1px solid #f0c27a; padding: .6em 1em .6em 2em; color: var(--warn); }
ul.notes li, ol.notes li, ul.warn li { margin: .2em 0; }
nav ol { margin: .2em 0 1em; list-style: none; padding-left: 1.2em; }
nav ol ol { margin: 0; }
.mute { color: var(--mute); }
footer { margin-top: 3em; font-size: .85em; color: var(--mute); border-top: 1px solid var(--rule); padding-top: .6em;
         overflow-wrap: anywhere; }
code { font-size: .92em; background: #f4f6f8; padding: 0 .25em; }

@media print {
  /* Paper: A4, or letter when the metadata says paper = "letter" (page_css), with its margins;
     every table fits the narrower of the two, 180 mm. */
  body { max-width: none; margin: 0; padding: 0; font-size: 9.5pt; line-height: 1.35; }
  h1 { font-size: 17pt; }
  h2 { font-size: 13pt; margin-top: 0; }
  h3 { font-size: 11.5pt; }
  h4 { font-size: 9.5pt; }
  section.major, section.result { break-before: page; }
  /* The front sections run on from the identification; the first result follows "5 Results". */
  section.front, section.major > h2 + section.result, section.major > p.lead + section.result { break-before: auto; }
  h2, h3, h4 { break-after: avoid; }
  h2 + *, h3 + *, h4 + *, h4 + div.scroll > table, h4 + table > tbody > tr:first-child { break-before: avoid; }
  figure, tr, table.ident, table.approval, p.what, p.rule, ul.warn { break-inside: avoid; }
  thead { display: table-header-group; }
  div.scroll { overflow: visible; }
  table { width: 100%; font-size: 8pt; }
  /* A word never breaks inside itself on paper ("lev el", "0. 27 1"): headers and cells wrap
     between words only, and the table's columns are sized to their longest word; only a text
     cell's long unbroken token (a hash, a path) breaks, and only where it cannot fit its line. */
  th, td { padding: 2px 3px; overflow-wrap: break-word; word-break: normal; hyphens: manual; }
  th { font-size: 7.5pt; }
  th.num, table.kv th { white-space: normal; }
  td.num { white-space: nowrap; overflow-wrap: normal; }
  table.kv td, td.any, footer { overflow-wrap: anywhere; }
  .iplot { display: none !important; }
  figure img.static { display: block !important; max-width: 100%; max-height: 200mm; width: auto; border: none; }
  details::details-content { content-visibility: visible; display: block; }
  details > summary { display: none; }
  p.what { background: none; }
  a { color: inherit; text-decoration: none; }
  nav { break-after: auto; }
  footer { font-size: 7pt; }
}
"""

# Draws every interactive twin; a figure that fails keeps its PNG and says why on the console.
BOOT_JS = """
(function () {
  var config = {responsive: true, displaylogo: false, edits: {legendPosition: true}};
  document.querySelectorAll("div.iplot").forEach(function (box) {
    var fig = box.parentNode;
    function fail(e) { box.remove(); console.error("vrelab: figure " + fig.id + " not drawn: " + e); }
    try {
      var spec = JSON.parse(document.getElementById(box.dataset.spec).textContent);
      Plotly.newPlot(box, spec.data, spec.layout, config).then(function () { fig.classList.add("live"); }, fail);
    } catch (e) { fail(e); }
  });
})();
"""


JS_CLASS = "document.documentElement.classList.add('js')"
