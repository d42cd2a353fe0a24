"""The report's pictures, one module each: the flight from above (:mod:`.trajectory`) and over time
(:mod:`.flight`), with the label placement they share (:mod:`.labels`). Drawn with matplotlib's Agg canvas, without
pyplot, so a run draws them in any thread and on any machine."""
