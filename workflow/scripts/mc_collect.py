"""Rule mc_collect: one table of one route of a case's realizations, in the route's order, each chunk
checked to hold exactly its share (rgns.montecarlo.tables.collect_listed); a route of the pairs in the
order rule paired_plan chose them."""

from rgns.logsetup import log_to_file
from rgns.montecarlo.routes import route_realizations
from rgns.montecarlo.tables import collect_listed
from rgns.tables import write_csv

log = log_to_file(snakemake.log[0])
listing = snakemake.params.listing
listed = route_realizations(listing["listed"], snakemake.input.plan)
table = collect_listed(snakemake.input.chunks, listed, listing["chunk_size"])
write_csv(table, snakemake.output[0])
log.info(
    "route %s: %d realizations from %d chunks, %d not ok",
    snakemake.wildcards.route,
    len(table),
    len(snakemake.input.chunks),
    int((table["status"] != "ok").sum()),
)
