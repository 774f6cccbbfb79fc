//! Lists the registered tasks: `cargo run --example list_tasks`.

fn main() {
    let _ = orbit::make; // links the built-in backends and tasks
    let _ = orbit::task_box_pushing::SUCCESS_DISTANCE;
    println!("{:<52} description", "task id");
    for task in orbit::managers::tasks() {
        println!("{:<52} {}", task.id, task.description);
    }
    println!(
        "\n{:<52} description (black-box: one movement primitive per episode)",
        "task id"
    );
    for task in orbit::managers::black_box_tasks() {
        println!("{:<52} {}", task.id, task.description);
    }
    println!(
        "\nphysics backends: {:?}",
        orbit::core::physics::backend_names()
    );
}
