"""The simulated shaker test's parts: the record generated on demand (:mod:`.record`) and the
test plan (:mod:`.plan`). :mod:`vrelab.shaker` runs them."""
