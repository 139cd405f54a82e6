"""The job planned before the stages, and what every stage's glue shares.

The names a command writes, the picture and the source it is scored against, the tiling and the
plate thickness it asks for, the primer, the cans and each layer's spray, the holes a plate
design gets (stippled, then refined, kept for the run) and what each stage returns for the recorder
to write (:mod:`.results`). Below :mod:`stencil_cad.pipeline`: no stage's glue imports another's;
they all import this.
"""
