/* The stream in flash, read in place by the decoder: scene_stream .. scene_stream_end. */
    .section .rodata.scene_stream, "a"
    .balign 8
    .global scene_stream, scene_stream_end
scene_stream:
    .incbin SCENE_STREAM_PATH
scene_stream_end:
