"""The project's own measurements, beside the product: the timing bench, the hop and
flood benches, and the network bench on namespaces."""
