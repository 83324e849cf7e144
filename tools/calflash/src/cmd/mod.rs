//! One module per subcommand, each a thin `run` over the library.

pub mod fit;
