"""The recorder and scope (docs/recorder.md): recordings of shared variables at every basic period,
from the trace rings into MCAP files under <data-dir>/recordings/, and triggered captures of the
rings' rows under <data-dir>/captures/.

Recordings: mcap_out.py writes a file, mcap_read.py reads one back (and completes one a crash cut
short), store.py keeps the folder and its quota, recording.py and manager.py run the recordings on
the agent's recorder thread, export.py makes CSV and Parquet of them.

Captures: triggers.py evaluates conditions on rows, capture.py is one capture's state,
capture_engine.py runs them on the capture thread, capture_sink.py writes their shots."""
