x.o: decoder/container.c decoder/cn_internal.h encoder/base/cn_buf.h
