"""The ``demo`` command: what the toolkit does today, end to end on an embedded scene.

It stores the embedded kitchen (an objects file shipped with the package), lists its
entities, exports it as Turtle and asks one SPARQL question of the stored graph.
"""

from __future__ import annotations

from importlib.resources import as_file, files
from pathlib import Path

import click

from causalsplat.cli._app import cli, echo_json, json_option

AFFORDANCE_QUERY = """
SELECT ?entity ?category WHERE {
  ?entity csg:category ?category ;
          csg:hasAttribute ?a .
  ?a csg:key "affordance" ;
     csg:value ?need .
} ORDER BY ?category"""


@cli.command("demo")
@click.option(
    "-o", "--output", type=click.Path(file_okay=False, path_type=Path),
    default=Path("demo-out"), show_default=True, help="Folder for the database and exports.",
)  # fmt: skip
@click.option("--db", "db_url", default=None, help="Database URL (default: OUTPUT/demo.db).")
@json_option
def demo(output: Path, db_url: str | None, as_json: bool) -> None:
    """Store the embedded kitchen scene, export it, and query it with SPARQL."""
    from causalsplat.api import open_store

    output.mkdir(parents=True, exist_ok=True)
    url = db_url or f"sqlite:///{output / 'demo.db'}"
    with open_store(url) as store, as_file(files("causalsplat") / "data/demo_kitchen.json") as src:
        scene = store.ingest_objects(src, if_exists="replace")
        turtle = output / f"{scene.id}.ttl"
        scene.export_rdf(turtle, format="turtle")
        need = "dry hands"
        result = scene.sparql(AFFORDANCE_QUERY, bindings={"need": need})
        graph = scene.graph
    answer = [{"entity": e, "category": c} for e, c in result.rows]
    if as_json:
        echo_json(
            {
                "db": url,
                "scene_id": graph.scene_id,
                "entities": len(graph.entities),
                "turtle": str(turtle),
                "question": f"what affords '{need}'?",
                "answer": answer,
            }
        )
        return
    click.echo(f"stored scene {graph.scene_id!r} in {url}: {len(graph.entities)} entities")
    for e in graph.entities:
        affordances = ", ".join(e.attribute_values("affordance")) or "-"
        click.echo(f"  {e.id:>3}  {e.category:<16} affords: {affordances}")
    click.echo(f"exported Turtle: {turtle}")
    click.echo(f"\nSPARQL, with ?need bound to {need!r}:{AFFORDANCE_QUERY}")
    for row in answer:
        click.echo(f"  -> {row['category']}  ({row['entity']})")
