/* Status names; compiled out with CNERF_NO_STATUS_STRINGS. */
#include "cnerf/cnerf.h"

#ifndef CNERF_NO_STATUS_STRINGS
const char *cnerf_status_str(cnerf_status s)
{
    switch (s) {
    case CNERF_OK: return "CNERF_OK";
    case CNERF_E_NULL: return "CNERF_E_NULL";
    case CNERF_E_ARG: return "CNERF_E_ARG";
    case CNERF_E_WS_ALIGN: return "CNERF_E_WS_ALIGN";
    case CNERF_E_WS_SMALL: return "CNERF_E_WS_SMALL";
    case CNERF_E_TRUNCATED: return "CNERF_E_TRUNCATED";
    case CNERF_E_MAGIC: return "CNERF_E_MAGIC";
    case CNERF_E_VERSION: return "CNERF_E_VERSION";
    case CNERF_E_CRC: return "CNERF_E_CRC";
    case CNERF_E_CHUNK_ORDER: return "CNERF_E_CHUNK_ORDER";
    case CNERF_E_UNKNOWN_CHUNK: return "CNERF_E_UNKNOWN_CHUNK";
    case CNERF_E_LIMIT: return "CNERF_E_LIMIT";
    case CNERF_E_HEADER: return "CNERF_E_HEADER";
    case CNERF_E_LAYER: return "CNERF_E_LAYER";
    case CNERF_E_RANGE: return "CNERF_E_RANGE";
    case CNERF_E_TABLE: return "CNERF_E_TABLE";
    case CNERF_E_PAYLOAD: return "CNERF_E_PAYLOAD";
    case CNERF_E_TRAILING: return "CNERF_E_TRAILING";
    case CNERF_E_FORMAT: return "CNERF_E_FORMAT";
    case CNERF_E_CHUNK: return "CNERF_E_CHUNK";
    case CNERF_E_OVERFLOW: return "CNERF_E_OVERFLOW";
    case CNERF_E_BUF_SMALL: return "CNERF_E_BUF_SMALL";
    case CNERF_E_IMAGE_ALIGN: return "CNERF_E_IMAGE_ALIGN";
    case CNERF_E_IMAGE_VERSION: return "CNERF_E_IMAGE_VERSION";
    case CNERF_E_IMAGE_TARGET: return "CNERF_E_IMAGE_TARGET";
    case CNERF_E_IMAGE_CRC: return "CNERF_E_IMAGE_CRC";
    case CNERF_E_IMAGE: return "CNERF_E_IMAGE";
    case CNERF_E_LEVEL: return "CNERF_E_LEVEL";
    case CNERF_E_LEVEL_EXCEEDED: return "CNERF_E_LEVEL_EXCEEDED";
    }
    return "CNERF_E_UNKNOWN_STATUS";
}
#endif
