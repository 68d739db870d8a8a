"""The pages crankfmu writes for people to read in a browser: the results page of a demo's outputs
(``results``), and the shared HTML, Markdown and MathML they and the FMUs' documentation are made
of (``markup``, ``mathml``). Pages read what the studies and the harness wrote; nothing here
computes physics."""
