"""alarms -- the agent's alarm manager (docs/alarms.md): what operators must look at, with its
ISA-18.2 state, history, acknowledgements and shelving.

- segment.py: reads irpd's alarm segment (the record ring and the sources' bitmaps), by the
  reader protocol of <indurop/alarms.h>, with every offset from shm_layout.json;
- manager.py: every alarm's state and transitions, acknowledge, shelve, reconcile, floods;
- store.py: the SQLite file they persist in (<data-dir>/alarms.sqlite3);
- system.py: the alarms the agent raises itself (irpd's events and status, irpd unreachable);
- watcher.py: the thread that reads the segment and polls irpd.

The routes are api/routes/alarms.py; irpctl's commands `alarms`, `ack`, `shelve`."""
