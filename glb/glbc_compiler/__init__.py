# glbc_compiler -- the .glb compiler behind glb/glbc: .glb files -> indurop/generated.h + layout.json.
#
# lexer (text -> tokens) -> parser (tokens -> per-file syntax) -> layout (names, sizes, offsets)
# -> evolve (with --previous: offsets and locks against the running layout) -> emit_header /
# emit_layout (the two outputs); errors carries file:line:col diagnostics and cli ties them
# together.  Standard library only.

__version__ = "0.1.0"
