//! The Vulkan instance and the validation hook.
//!
//! Validation (`ISPM_VALIDATION=1`, and always in the tests) enables
//! `VK_LAYER_KHRONOS_validation` with synchronization validation (unless
//! `GpuOptions::without_sync_validation`) through
//! `VkValidationFeaturesEXT` (layer 1.3.239 has no `VK_EXT_layer_settings`). A debug messenger is
//! chained into instance creation *and* created persistently, because a chained one sees only
//! `vkCreateInstance`/`vkDestroyInstance`. The messenger counts validation and performance
//! warnings and errors; general messages (the loader's chatter) are logged at debug level only.

use super::error::{vk_err, GpuError, GpuResult};
use ash::vk;
use std::ffi::{c_void, CStr};
use std::sync::Mutex;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Messages the validation layer reported. Shared with the messenger callback.
#[derive(Debug, Default)]
pub struct ValidationLog {
    messages: Mutex<Vec<String>>,
}

impl ValidationLog {
    /// Every counted message so far.
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }

    pub fn count(&self) -> usize {
        self.messages.lock().map(|m| m.len()).unwrap_or(0)
    }

    fn push(&self, message: String) {
        if let Ok(mut m) = self.messages.lock() {
            m.push(message);
        }
    }
}

/// Whether the environment asks for validation (`ISPM_VALIDATION=1`).
pub fn validation_requested() -> bool {
    std::env::var("ISPM_VALIDATION").is_ok_and(|v| v != "0" && !v.is_empty())
}

/// The instance, its persistent debug messenger and the log the messenger writes into.
/// Dropping it destroys the messenger, then the instance, then frees the log, so every error
/// path after instance creation cleans up by dropping this.
pub(super) struct InstanceParts {
    /// Keeps the Vulkan loader library loaded while the instance lives.
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    debug_utils: ash::ext::debug_utils::Instance,
    messenger: vk::DebugUtilsMessengerEXT,
    /// Owned through a raw pointer (from `Box::into_raw`): the messenger's user data aliases it
    /// for the messenger's whole life, so no `Box` may be moved while it runs.
    log: *mut ValidationLog,
}

// SAFETY: the log is only accessed through `&ValidationLog`, whose interior is a Mutex; the
// Vulkan handles are plain values that the spec allows using from any thread.
unsafe impl Send for InstanceParts {}
// SAFETY: as above; nothing in InstanceParts is mutated through a shared reference except the
// Mutex-protected log.
unsafe impl Sync for InstanceParts {}

impl InstanceParts {
    pub fn log(&self) -> &ValidationLog {
        // SAFETY: `log` came from Box::into_raw in create_instance and is freed only in Drop.
        unsafe { &*self.log }
    }
}

impl Drop for InstanceParts {
    fn drop(&mut self) {
        // SAFETY: the owner of this value destroyed every device and object made from the
        // instance before dropping it (Gpu::drop does so); the messenger is destroyed before
        // the log it points at is freed.
        unsafe {
            self.debug_utils
                .destroy_debug_utils_messenger(self.messenger, None);
            self.instance.destroy_instance(None);
            drop(Box::from_raw(self.log));
        }
    }
}

/// The instance, with the validation layer when `validation.0` and its synchronization
/// validation when `validation.1` as well.
pub(super) fn create_instance(
    (validation, sync_validation): (bool, bool),
    extra_extensions: &[&CStr],
) -> GpuResult<InstanceParts> {
    // SAFETY: loading the Vulkan loader library runs its initialisers; we load the system's
    // libvulkan, which is trusted like any other system library.
    let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loader(e.to_string()))?;

    if validation {
        // SAFETY: entry is a loaded Vulkan entry; the call has no other preconditions.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(vk_err("vkEnumerateInstanceLayerProperties"))?;
        let found = layers
            .iter()
            .any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER));
        if !found {
            return Err(GpuError::ValidationLayerMissing);
        }
    }

    let app = vk::ApplicationInfo::default()
        .application_name(c"ispm")
        .application_version(vk::make_api_version(0, 0, 1, 0))
        .engine_name(c"ispm")
        .api_version(vk::API_VERSION_1_3);

    let mut extensions: Vec<*const i8> = vec![ash::ext::debug_utils::NAME.as_ptr()];
    extensions.extend(extra_extensions.iter().map(|e| e.as_ptr()));
    let mut layers: Vec<*const i8> = Vec::new();
    if validation {
        layers.push(VALIDATION_LAYER.as_ptr());
        extensions.push(ash::ext::validation_features::NAME.as_ptr());
    }

    let log = Box::into_raw(Box::<ValidationLog>::default());
    let log_ptr = log.cast::<c_void>();
    let mut messenger_info = messenger_create_info(log_ptr);
    let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);

    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_extension_names(&extensions)
        .enabled_layer_names(&layers)
        .push_next(&mut messenger_info);
    if validation && sync_validation {
        info = info.push_next(&mut features);
    }

    // SAFETY: every pointer in `info` refers to locals that outlive the call; the messenger's user
    // data points at `log`, which lives until InstanceParts is dropped.
    let instance = match unsafe { entry.create_instance(&info, None) } {
        Ok(i) => i,
        Err(e) => {
            // SAFETY: `log` came from Box::into_raw above and nothing refers to it any more.
            drop(unsafe { Box::from_raw(log) });
            return Err(vk_err("vkCreateInstance")(e));
        }
    };
    let debug_utils = ash::ext::debug_utils::Instance::new(&entry, &instance);
    let persistent = messenger_create_info(log_ptr);
    // SAFETY: the instance is live and was created with VK_EXT_debug_utils enabled; user data
    // points at the boxed log, which outlives the messenger (destroyed before the instance).
    let messenger = match unsafe { debug_utils.create_debug_utils_messenger(&persistent, None) } {
        Ok(m) => m,
        Err(e) => {
            // SAFETY: nothing was created from the instance; `log` is referenced by nothing.
            unsafe {
                instance.destroy_instance(None);
                drop(Box::from_raw(log));
            }
            return Err(vk_err("vkCreateDebugUtilsMessengerEXT")(e));
        }
    };
    Ok(InstanceParts {
        entry,
        instance,
        debug_utils,
        messenger,
        log,
    })
}

fn messenger_create_info(user_data: *mut c_void) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug_callback))
        .user_data(user_data)
}

/// Counts validation/performance warnings and errors into the [`ValidationLog`] behind
/// `user_data`; everything else goes to the debug log.
unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the layer passes a valid callback-data pointer (or null) for the duration of
    // the call.
    let message = unsafe { data.as_ref() }
        // SAFETY: p_message is a NUL-terminated string owned by the layer for this call.
        .and_then(|d| unsafe { d.message_as_c_str() })
        .map(|m| m.to_string_lossy().into_owned())
        .unwrap_or_default();
    let counted = types.intersects(
        vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
            | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
    ) && severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    );
    if counted {
        log::error!("validation: {message}");
        // SAFETY: user_data is the address of the boxed ValidationLog that outlives the
        // messenger (see create_instance).
        if let Some(log) = unsafe { user_data.cast::<ValidationLog>().as_ref() } {
            log.push(message);
        }
    } else {
        log::debug!("vulkan: {message}");
    }
    vk::FALSE
}
