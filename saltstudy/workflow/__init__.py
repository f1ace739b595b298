"""Task graph, cache keys, archive I/O, dask execution and the saltation driver loop."""
