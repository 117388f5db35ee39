x.o: common/cn_reader.h decoder/cn_internal.h
