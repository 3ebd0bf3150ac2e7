"""Files RAST writes: output files written whole and only over regular files
(``outputs``), the streams' RAM files and manifest (``ramfiles``)."""
