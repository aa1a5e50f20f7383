"""stream_frame_spec.py -- the stream frame's constants, GENERATED from protocol/stream/frame.json by
protocol/stream/generate.py: do not edit; change the spec and run `python3 protocol/stream/generate.py`.
The encoder and decoder that use them: stream_frame.py."""

MAGIC = b'IRPS'
VERSION = 1
KINDS = {'samples': 1}
HEADER_FORMAT = '<4sHHQIIQ'
HEADER_SIZE = 32
HEADER_FIELDS = ('magic', 'version', 'kind', 'first_seq', 'count', 'channels', 'dropped')
OFFSETS = {'magic': 0, 'version': 4, 'kind': 6, 'first_seq': 8, 'count': 16, 'channels': 20, 'dropped': 24}
FORMATS = {'magic': '4s', 'version': 'H', 'kind': 'H', 'first_seq': 'Q', 'count': 'I', 'channels': 'I', 'dropped': 'Q'}  # struct code of each header field
# (name, struct code of each value, header field giving the values' count, header field giving
# how many such runs follow one another or None), in frame order
BODY = (('t_ns', 'q', 'count', None), ('columns', 'd', 'count', 'channels'))
