# plcopen_export -- the ST compiler's tree (stc_compiler.tree Units) written as a PLCopen XML 2.01 project.
from .project import export, export_files, import_unit

__all__ = ["export", "export_files", "import_unit"]
