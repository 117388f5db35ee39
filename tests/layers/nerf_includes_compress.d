x.o: encoder/nerf/train.c encoder/nerf/cn_train.h \
 encoder/compress/cn_grid.h /usr/include/stdio.h
