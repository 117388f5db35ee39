x.o: decoder/parse.c decoder/cn_internal.h encoder/base/cn_buf.h
