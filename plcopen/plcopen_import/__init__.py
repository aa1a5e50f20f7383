# plcopen_import -- PLCopen XML (TC6 XML v2.01) -> the ST compiler's tree (st/stc_compiler/tree.py):
# read.py (safe parse, schema), graph.py (graphical bodies as graphs), then the translations.
