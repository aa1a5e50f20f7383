"""sets -- the set store (docs/set-store.md): the stored sets and their versions (store.py), set
uploads received and checked (uploads.py, archives.py for the .tar.gz a client sends, elf_check.py
for the binaries), activation and rollback into irpd and the restore watcher (activation.py), and
the errors that point into a set's files (errors.py)."""
