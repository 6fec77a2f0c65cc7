//! Built-in mesh generators. TODO(helper: generators): box and cubed-sphere meshes.
