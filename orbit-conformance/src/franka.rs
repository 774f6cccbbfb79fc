//! franka
