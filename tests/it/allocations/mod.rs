//! The step loops allocate nothing, counted by the binary's global allocator
//! ([`counter::CountingAllocator`]) on the threads of the measured work only.

pub mod counter;
mod env;
mod physics;
