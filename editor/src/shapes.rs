//! Shapes (parry2d) and their conservative rasterisation into a quadtree.
