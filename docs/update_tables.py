"""Rewrite the option tables of the documentation from the package's registries.

    python docs/update_tables.py

Every ``<!-- registry: NAME -->`` ... ``<!-- /registry -->`` block in ``docs/*.md`` is
replaced by the table of that option family, so that adding a Laplacian, a solver, a
filtration or a metric to its registry is the only change the documentation needs
(``tests/test_docs.py`` fails until this script has been run).
"""

from pathlib import Path

from sklearn_meshph._registry import update_tables
from sklearn_meshph.pipelines import all_registries

registries = all_registries()
for page in sorted(Path(__file__).parent.glob("*.md")):
    text = page.read_text()
    updated = update_tables(text, registries)
    if updated != text:
        page.write_text(updated)
        print(f"updated {page}")
