x.o: encoder/stream/writer.c encoder/stream/cn_stream.h \
 decoder/cn_internal.h
